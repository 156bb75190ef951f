"""Jobs built on the library: each module is one command's work, importable on its own.

- :mod:`synth.jobs.bench` — the benchmarks of ``stereoforge bench``, one module a table.
- :mod:`synth.jobs.golden` — golden references: exact matcher outputs, tolerant render checks
  (:mod:`synth.jobs.golden_compare`: the render tolerances). They stay modules here: the
  generated ``golden/README.md``, hashed in ``golden/manifest.json``, names this path.
- :mod:`synth.jobs.paper` — the seed paper's Tables 1-3 on the real Middlebury scenes.
- :mod:`synth.jobs.study` — the texture-versus-window study: run, configuration, report.
- :mod:`synth.jobs.train` — the reference network's trainer (torch only here).
- :mod:`synth.jobs.demo` — every preset rendered, and a contact sheet.
- :mod:`synth.jobs.evaluate` — metrics of a disparity file against a ground-truth file.
- :mod:`synth.jobs.eval_dataset` — any matcher scored on a dataset folder.

Nothing is imported here: a job pulls in what it needs (matplotlib, the renderer, the dataset
engine) when its module is imported.
"""

__all__: list[str] = []
