"""Jobs built on the library: each module is one command's work, importable on its own.

- :mod:`synth.jobs.demo` — every preset rendered, and a contact sheet.
- :mod:`synth.jobs.golden` — golden references: exact matcher outputs, tolerant render checks.
- :mod:`synth.jobs.paper` — the seed paper's Tables 1-3 on the real Middlebury scenes.
- :mod:`synth.jobs.evaluate` — metrics of a disparity file against a ground-truth file.
- :mod:`synth.jobs.study`, :mod:`~synth.jobs.study_config`, :mod:`~synth.jobs.study_report` — the
  texture-versus-window study: run, configuration, summary and figures.
- :mod:`synth.jobs.bench_render`, :mod:`~synth.jobs.bench_dataset`, :mod:`~synth.jobs.bench_match`,
  :mod:`~synth.jobs.bench_paper` — the speed tables of ``stereoforge bench``.

Nothing is imported here: a job pulls in what it needs (matplotlib, the renderer, the dataset
engine) when its module is imported.
"""

__all__: list[str] = []
