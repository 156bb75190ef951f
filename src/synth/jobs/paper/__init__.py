"""The ``paper`` report: the seed paper's experiments on the real Middlebury scenes.

- :mod:`synth.jobs.paper.tables` — :func:`~synth.jobs.paper.tables.run_paper`: Tables 1-3 and
  the figures' data.
- :mod:`synth.jobs.paper.figures` — the figures, beside the paper's own numbers.

Nothing is imported here (matplotlib only with the figures).
"""

__all__: list[str] = []
