"""The rig drawn per sample: ``[rig]`` keys written as distributions.

``baseline``, ``fx`` (the field of view), ``pitch`` and ``camera_height`` (the rig's pose in its
layout: :mod:`scenes.posing`) may be ``{uniform = [a, b]}``, ``{loguniform = [a, b]}`` or
``{choice = [...]}`` like the ``[scene]`` keys (wide-baseline data: ``baseline = {uniform =
[0.04, 0.4]}``; a room seen from a child's height to a tall adult's, looking a little up or
down: ``camera_height = {uniform = [0.5, 2.0]}``, ``pitch = {uniform = [-10.0, 25.0]}``); every
other ``[rig]`` key is one value (the image size, the near and far planes, the camera errors). Each
sample then draws its own values from stream 8 of its seed (:func:`draw_rig`), after nothing
else, so a configuration without rig distributions draws what it drew, and one with them draws
every other parameter as it would with fixed values. The drawn values are in the sample's
params (``rig.baseline``, ``rig.fx``, ``rig.pitch``, ``rig.camera_height``: the pose keys are
recorded even when fixed, and move the base preset's scene before anything is added to it); every
layout writes the sample's own calibration
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

__all__ = ["RIG_DRAW_KEYS", "nominal", "draw_rig", "extreme_rigs", "config_rigs", "STREAM_RIG",
           "pose_problem"]

#: The ``[rig]`` keys that may be distributions (the cameras' first, then the rig's pose).
RIG_DRAW_KEYS = ("baseline", "fx", "pitch", "camera_height")
_CAMERA_DRAW_KEYS = ("baseline", "fx")
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
    changes = {k: v for k, v in values.items() if k in _CAMERA_DRAW_KEYS}
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
    keys = [k for k in _CAMERA_DRAW_KEYS if k in draws]
    if not keys:
        return [rig]
    ends = [(min(draws[k].args), max(draws[k].args)) for k in keys]
    return [_with(rig, dict(zip(keys, combo)), fy_follows)
            for combo in itertools.product(*ends)]


def config_rigs(config: Any) -> list[StereoRig]:
    """Every rig a configuration's samples may take at its extremes (of each part of a mix)."""
    return [rig for part in (config.parts or (config,))
            for rig in extreme_rigs(part.rig, part.rig_draws,
                                    fy_follows=part.rig.fy == part.rig.fx)]


def pose_problem(draws: Mapping[str, Any], base: Any) -> tuple[str, str, str] | None:
    """``(expected, actual, fix)`` when ``camera_height`` is set but a base preset the
    configuration may draw (``base``: its Dist) has no floor (:func:`scenes.posing.floor_height`);
    else None."""
    if "camera_height" not in draws:
        return None
    from scenes import get_preset
    from scenes.posing import FLOOR_NAMES, floor_height

    names = base.args if base.kind == "choice" else (base.args[0],)
    bare = [str(n) for n in names if floor_height(get_preset(str(n), seed=0)) is None]
    if not bare:
        return None
    return (f"a base with a floor (an object named {' or '.join(FLOOR_NAMES)}: room, outdoor)",
            f"base {bare[0]!r}, which has none",
            "leave camera_height out, or draw base among the layouts with a floor")
