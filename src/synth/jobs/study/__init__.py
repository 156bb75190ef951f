"""The texture-versus-window study (``stereoforge study``).

- :mod:`synth.jobs.study.run` — the study: scenes, matchers, the resumable cells.
- :mod:`synth.jobs.study.config` — its TOML configuration, validated, errors with file and line.
- :mod:`synth.jobs.study.report` — ``summary.md`` and the figures.

Nothing is imported here: :mod:`synth.jobs.study.run` is what the worker server preloads.
"""

__all__: list[str] = []
