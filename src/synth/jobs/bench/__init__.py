"""The benchmarks of ``stereoforge bench``: each module one table, and what they share.

- :mod:`synth.jobs.bench.render` — render speed, and the tables' writer (Markdown and CSV).
- :mod:`synth.jobs.bench.dataset` — dataset throughput and the edge density check.
- :mod:`synth.jobs.bench.match` — :func:`matcher.match` against OpenCV StereoBM / StereoSGBM.
- :mod:`synth.jobs.bench.paper` — the seed paper's methods (CTHW, AWCT, AWSCT) against CT/SCT.
- :mod:`synth.jobs.bench.realism` — do matchers find our pairs as hard as real scenes?
- :mod:`synth.jobs.bench.transfer` — the reference network trained on each config, scored on
  real scenes (torch only in the trainer's own process).
- :mod:`synth.jobs.bench.validate` — wall time of a whole ``validate`` run.
- :mod:`synth.jobs.bench.timing` — wall-clock times of a call that may compile numba kernels.
- :mod:`synth.jobs.bench.machine` — what a benchmark ran on, written with every table.

Nothing is imported here: a benchmark pulls in what it needs when its module is imported.
"""

__all__: list[str] = []
