"""``stereoforge validate``: stress any matcher on controlled axes, score it per region, report.

- :mod:`synth.validate.family` — the base scenes, one drawn per seed of a suite
- :mod:`synth.validate.axes` — the axes registry (one-parameter sweeps of each seed's config)
- :mod:`synth.validate.pairs` — the pair folders with their region masks, rendered once
- :mod:`synth.validate.real` — real scenes (``--real``) as pair folders beside the axes
- :mod:`synth.validate.run` — the run: pairs, estimates, ``results.csv``, battery and report
- :mod:`synth.validate.differences` — paired differences, regressions, ``differences.csv``
- :mod:`synth.validate.baseline` — finished runs as baselines (``--baseline``, ``--compare``)
- :mod:`synth.validate.properties` — the property battery (hypothesis) and ``properties.json``
- :mod:`synth.validate.figures`, :mod:`synth.validate.report` — the self-contained ``report.html``

The battery and the report are not imported here (hypothesis and the figure code load when
``run_validate`` runs them, or when their modules are imported).
"""

from synth.validate.axes import AXES, SUITES, Axis, register_axis
from synth.validate.run import COLUMNS, DEFAULT_AGAINST, ValidateResult, run_validate

__all__ = ["AXES", "SUITES", "Axis", "register_axis", "COLUMNS", "DEFAULT_AGAINST",
           "ValidateResult", "run_validate"]
