"""``stereoforge validate``: stress any matcher on controlled axes, score it per region.

- :mod:`synth.validate.axes` — the axes registry (one-parameter sweeps of a base dataset config)
- :mod:`synth.validate.pairs` — the pair folders with their region masks, rendered once
- :mod:`synth.validate.run` — the run: pairs, estimates, ``results.csv``, battery and report
"""

from synth.validate.axes import AXES, SUITES, Axis, register_axis
from synth.validate.run import COLUMNS, DEFAULT_AGAINST, ValidateResult, run_validate

__all__ = ["AXES", "SUITES", "Axis", "register_axis", "COLUMNS", "DEFAULT_AGAINST",
           "ValidateResult", "run_validate"]
