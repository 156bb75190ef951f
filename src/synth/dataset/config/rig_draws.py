"""The rig drawn per sample: ``[rig]`` keys written as distributions.

``baseline`` and ``fx`` (the field of view) may be ``{uniform = [a, b]}``,
``{loguniform = [a, b]}`` or ``{choice = [...]}`` like the ``[scene]`` keys (wide-baseline
data: ``baseline = {uniform = [0.04, 0.4]}``); every other ``[rig]`` key is one value. Each
sample then draws its own values from stream 8 of its seed (:func:`draw_rig`), after nothing
else, so a configuration without rig distributions draws what it drew, and one with them draws
every other parameter as it would with fixed values. The drawn values are in the sample's
params (``rig.baseline``, ``rig.fx``); every layout writes the sample's own calibration
(``calib.txt``, KITTI's ``calib_cam_to_cam``), and ``fy`` follows a drawn ``fx`` unless it is
set. A layout's limits (integer disparities, their range) are checked at the extremes of the
draws (:func:`extreme_rigs`).
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Mapping
from typing import Any

import numpy as np

from synth.camera.rig import StereoRig

__all__ = ["RIG_DRAW_KEYS", "nominal", "draw_rig", "extreme_rigs", "config_rigs", "STREAM_RIG"]

#: The ``[rig]`` keys that may be distributions.
RIG_DRAW_KEYS = ("baseline", "fx")
#: The sample-seed stream the rig is drawn from (after the scene's streams 0-7).
STREAM_RIG = 8


def nominal(dist: Any) -> float:
    """The value a drawn key stands at in the configuration's nominal rig (``config.rig``):
    the middle of a uniform, the geometric middle of a log-uniform, the first choice.

    Examples
    --------
    >>> from synth.dataset.config.dists import Dist
    >>> nominal(Dist("uniform", (0.04, 0.4))), nominal(Dist("loguniform", (1.0, 4.0)))
    (0.22, 2.0)
    """
    if dist.kind == "uniform":
        return float((dist.args[0] + dist.args[1]) / 2)
    if dist.kind == "loguniform":
        return float(np.sqrt(dist.args[0] * dist.args[1]))
    return float(dist.args[0])


def _with(rig: StereoRig, values: Mapping[str, float], fy_follows: bool) -> StereoRig:
    changes = dict(values)
    if "fx" in changes and fy_follows:
        changes["fy"] = changes["fx"]
    return dataclasses.replace(rig, **changes)


def draw_rig(rig: StereoRig, draws: Mapping[str, Any], seed: int, *, fy_follows: bool
             ) -> tuple[StereoRig, dict[str, float]]:
    """The rig of the sample with ``seed``: ``rig`` with each key of ``draws`` drawn (in
    :data:`RIG_DRAW_KEYS` order) from stream :data:`STREAM_RIG`, and the drawn values."""
    if not draws:
        return rig, {}
    # sampling.stream(seed, STREAM_RIG), the same generator
    rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(STREAM_RIG,)))
    values = {k: float(draws[k].sample(rng)) for k in RIG_DRAW_KEYS if k in draws}
    return _with(rig, values, fy_follows), values


def extreme_rigs(rig: StereoRig, draws: Mapping[str, Any], *, fy_follows: bool
                 ) -> list[StereoRig]:
    """``rig`` at every combination of each drawn key's smallest and largest value (the
    nominal rig alone when nothing is drawn): where a layout's disparity limits bind."""
    if not draws:
        return [rig]
    keys = [k for k in RIG_DRAW_KEYS if k in draws]
    ends = [(min(draws[k].args), max(draws[k].args)) for k in keys]
    return [_with(rig, dict(zip(keys, combo)), fy_follows)
            for combo in itertools.product(*ends)]


def config_rigs(config: Any) -> list[StereoRig]:
    """Every rig a configuration's samples may take at its extremes (of each part of a mix)."""
    return [rig for part in (config.parts or (config,))
            for rig in extreme_rigs(part.rig, part.rig_draws,
                                    fy_follows=part.rig.fy == part.rig.fx)]
