"""The axes of ``stereoforge validate``: one-parameter sweeps of a fixed base dataset config.

Every pair of a validation is one sample of a dataset configuration
(:mod:`synth.dataset.config.parse`, the same schema as ``stereoforge dataset``): :func:`base_config`
for the suite, with **one** value changed by an axis. An :class:`Axis` says how a value changes it:

- ``key``: a dataset-config key ``"section.key"`` (``"photometric.noise_sigma"``,
  ``"rig.baseline"``, ...) set to the value; or ``config``, a function editing the config dict
  (:meth:`DatasetConfig.to_dict` form) in place, for a change of several keys;
- ``scene`` (optional): a module-level function ``(scene, rig, value) -> scene`` applied to the
  drawn scene before rendering, for what no config key expresses yet (slant, textureless area).

Adding a hazard in a few lines, once its dataset-config key exists (e.g. ``material.specular``)::

    from synth.validate.axes import Axis, register_axis
    register_axis(Axis("specular", "specular strength of every surface",
                       quick=(0.0, 0.5, 1.0), full=(0.0, 0.25, 0.5, 0.75, 1.0),
                       key="material.specular"))

(put the call at the end of this module, so workers see it too). Axes are looked up by name in
the worker processes, so ``config`` and ``scene`` must be module-level functions.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace
from typing import Any, Callable

__all__ = ["Axis", "AXES", "SUITES", "register_axis", "get_axis", "base_config",
           "axis_config"]

#: Suites: rig size, seeds (sample indices of the base config) and which values each axis uses.
SUITES = {
    "quick": {"width": 320, "height": 240, "seeds": (0, 1, 2)},
    "full": {"width": 640, "height": 480, "seeds": (0, 1, 2, 3, 4)},
}


@dataclass(frozen=True)
class Axis:
    """One sweep: a name, its values per suite, and how a value changes the base config.

    Attributes
    ----------
    name : str
        Column ``axis`` of results.csv.
    doc : str
        What the value is, with its unit.
    quick, full : tuple of float
        Values of the quick and the full suite.
    key : str or None
        ``"section.key"`` of the dataset config set to the value.
    config : callable or None
        ``f(config_dict, value)`` editing the config dict in place (instead of, or after, key).
    scene : callable or None
        ``f(scene, rig, value) -> scene`` applied to the drawn scene.
    """

    name: str
    doc: str
    quick: tuple[float, ...]
    full: tuple[float, ...]
    key: str | None = None
    config: Callable[[dict, Any], None] | None = None
    scene: Callable[[Any, Any, Any], Any] | None = None

    def values(self, suite: str) -> tuple[float, ...]:
        return self.quick if suite == "quick" else self.full


AXES: dict[str, Axis] = {}


def register_axis(axis: Axis) -> Axis:
    """Add ``axis`` to :data:`AXES` (replacing one of the same name) and return it."""
    if not isinstance(axis, Axis):
        raise TypeError(f"axis must be an Axis, got {type(axis).__name__}")
    if axis.key is None and axis.config is None and axis.scene is None:
        raise ValueError(f"axis {axis.name!r}: give key, config or scene")
    AXES[axis.name] = axis
    return axis


def get_axis(name: str) -> Axis:
    if name not in AXES:
        raise KeyError(f"unknown axis {name!r}; axes: {', '.join(AXES)}")
    return AXES[name]


def base_config(suite: str, seed: int = 0) -> dict:
    """The base dataset config (dict form) of a suite's seed ``seed``: the seed's own base scene
    (:func:`synth.validate.family.base_scene`: boxes, flying objects, a slanted plane or a
    Moebius strip, with occluders and procedural or photo textures), texture contrast 0.8, a
    0.2 m baseline and sensor noise of 1 grey level; every other model off."""
    from synth.validate.family import base_scene

    size = SUITES[suite]
    return {
        "name": f"validate-{suite}", "seed": 0, "count": max(size["seeds"]) + 1,
        "preview": False,
        "rig": {"width": size["width"], "height": size["height"], "baseline": 0.2},
        "scene": base_scene(seed),
        "photometric": {"noise_sigma": 1.0},
    }


def axis_config(suite: str, axis: Axis, value: Any, seed: int = 0) -> dict:
    """The base config of ``suite``'s seed ``seed`` with ``axis`` set to ``value`` (a new dict)."""
    cfg = copy.deepcopy(base_config(suite, seed))
    if axis.key is not None:
        section, _, key = axis.key.rpartition(".")
        cfg.setdefault(section, {})[key] = value
    if axis.config is not None:
        axis.config(cfg, value)
    return cfg


# --------------------------------------------------------------------------- scene changes
def _procedural(cfg: dict) -> None:
    """Drop a member's photographs (:data:`synth.validate.family.PHOTO_KEYS`)."""
    from synth.validate.family import PHOTO_KEYS

    for key in PHOTO_KEYS:
        cfg["scene"].pop(key, None)


def _repetitive(cfg: dict, period_px: float) -> None:
    _procedural(cfg)
    cfg["scene"].update(texture="stripes", frequency_px=1.0 / float(period_px))


def _edge_density(cfg: dict, value: float) -> None:
    _procedural(cfg)  # the closed-loop search drives procedural textures only
    cfg["scene"].pop("frequency_px", None)  # edge_density chooses the frequency


def _slant(scene: Any, rig: Any, degrees: float) -> Any:
    """One textured plane through (baseline / 2, 0, 2.5 m) turned by ``degrees`` about the
    vertical axis (0 = fronto-parallel), cut to cover both views with a margin."""
    from scenes import ObjectSpec, Pose
    from synth.appearance.texture_control import retexture

    theta = math.radians(float(degrees))
    x0, z0 = rig.baseline / 2, 2.5
    t_edge = 1.15 * (rig.width / 2) / rig.fx  # tangent of the half field of view, with margin
    # along the plane (direction (cos, 0, -sin)), where the rays of each view's edges meet it
    hits = [(c + z0 * t - x0) / (math.cos(theta) + t * math.sin(theta))
            for c in (0.0, rig.baseline) for t in (-t_edge, t_edge)]
    lo, hi = min(hits), max(hits)
    lo, hi = lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)
    mid = (lo + hi) / 2
    far = z0 - lo * math.sin(theta)
    texture = scene.objects[-1].texture  # the wall's: already retextured by the config
    plane = ObjectSpec("plane", Pose(translation=(x0 + mid * math.cos(theta), 0.0,
                                                  z0 - mid * math.sin(theta)),
                                     rotation_deg=(0.0, float(degrees), 0.0)),
                       (hi - lo, 2.6 * far * (rig.height / 2) / rig.fy), texture, name="plane")
    out = replace(scene, objects=(plane,))
    wall_z = scene.objects[-1].pose.translation[2]
    f_px = texture.frequency * wall_z / rig.fx  # the wall's image frequency at the plane's centre
    return retexture(out, fx=rig.fx, frequency_px=f_px)


def _nearest_depth(scene: Any) -> float:
    """The smallest depth of any vertex of the scene's objects (their meshes, untextured)."""
    from scenes import TextureSpec
    from scenes.primitives import build_mesh

    plain = TextureSpec(kind="constant")
    return min(float(build_mesh(replace(o, texture=plain)).vertices[:, 2].min())
               for o in scene.objects)


def _textureless_card(scene: Any, rig: Any, fraction: float) -> Any:
    """A constant-grey card covering ``fraction`` of the image, centred, in front of every
    object (at 0.9 of the nearest vertex's depth); 0 adds nothing."""
    from scenes import ObjectSpec, Pose, TextureSpec

    fraction = float(fraction)
    if fraction <= 0:
        return scene
    z = 0.9 * _nearest_depth(scene)
    side = math.sqrt(fraction)
    size = (side * rig.width * z / rig.fx, side * rig.height * z / rig.fy)
    card = ObjectSpec("plane", Pose(translation=(0.0, 0.0, z)), size,
                      TextureSpec(kind="constant", mean=0.5), name="textureless_card")
    return replace(scene, objects=(card, *scene.objects))


def _specular(cfg: dict, strength: float) -> None:
    """Every object specular (Blinn-Phong, the default shininess 32) with ``strength``; 0 = matte."""
    if float(strength) > 0:
        cfg["scene"].update(specular_fraction=1.0, specular=float(strength))


def _fences(scene: Any, rig: Any, count: int) -> Any:
    """``count`` wire fences in front of every object (at 0.9 of the nearest vertex's depth),
    each a square of 15 % of the image width with six bars 1.5 px thick, centred at a pixel of
    the middle 80 % of the view drawn from the scene's seed, turned about the optical axis and
    up to 30 degrees about the vertical; 0 adds nothing."""
    import numpy as np

    from scenes import ObjectSpec, Pose, TextureSpec

    if int(count) <= 0:
        return scene
    rng = np.random.default_rng(scene.seed)
    z = 0.9 * _nearest_depth(scene)
    side = 0.15 * rig.width * z / rig.fx
    size = (side, side, side / 6.0, min(max(side / 40.0, 1.5 * z / rig.fx), side / 12.0))
    fences = []
    for i in range(int(count)):
        u, v = rng.uniform(0.1, 0.9) * rig.width, rng.uniform(0.1, 0.9) * rig.height
        pose = Pose(translation=((u - rig.cx) * z / rig.fx, (v - rig.cy) * z / rig.fy, z),
                    rotation_deg=(0.0, float(rng.uniform(-30.0, 30.0)),
                                  float(rng.uniform(0.0, 180.0))))
        texture = TextureSpec(kind="noise", frequency=0.125 * rig.fx / z, contrast=0.8,
                              mean=float(rng.uniform(0.3, 0.7)), seed=int(rng.integers(0, 2**62)))
        fences.append(ObjectSpec("fence", pose, size, texture, name=f"fence{i}"))
    return replace(scene, objects=(*fences, *scene.objects))


def _exposure(cfg: dict, factor: float) -> None:
    """The right camera's exposure times ``factor`` (linear light); 1 = the same exposure."""
    if float(factor) != 1.0:
        cfg["scene"]["exposure_variant"] = float(factor)


def _lighting(cfg: dict, degrees: float) -> None:
    """The right view lit by the light directions turned by ``degrees``; 0 = the same light."""
    if float(degrees) > 0:
        cfg["scene"]["lighting_variant"] = float(degrees)


# --------------------------------------------------------------------------- the registry
for _axis in (
    Axis("texture_frequency", "texture frequency, cycles per pixel", (0.05, 0.125, 0.3),
         (0.03, 0.05, 0.08, 0.125, 0.2, 0.3, 0.4), key="scene.frequency_px"),
    Axis("contrast", "texture contrast, 0..1", (0.05, 0.2, 0.8),
         (0.02, 0.05, 0.1, 0.2, 0.4, 0.8), key="scene.contrast"),
    Axis("edge_density", "Canny edge density of the left image (closed loop)", (0.03, 0.1, 0.25),
         (0.02, 0.05, 0.1, 0.15, 0.25, 0.35), key="scene.edge_density", config=_edge_density),
    Axis("noise", "sensor noise sigma, grey levels", (0.0, 4.0, 16.0),
         (0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0), key="photometric.noise_sigma"),
    Axis("gain", "right/left gain", (0.7, 1.0, 1.4), (0.5, 0.7, 0.85, 1.0, 1.2, 1.4, 2.0),
         key="photometric.gain"),
    Axis("bias", "right/left bias, grey levels", (-30.0, 0.0, 30.0),
         (-60.0, -30.0, -10.0, 0.0, 10.0, 30.0, 60.0), key="photometric.bias"),
    Axis("gamma", "gamma of both images", (0.5, 1.0, 2.0), (0.4, 0.6, 0.8, 1.0, 1.5, 2.0, 2.5),
         key="photometric.gamma"),
    Axis("blur", "Gaussian blur sigma, pixels", (0.0, 1.0, 2.5), (0.0, 0.5, 1.0, 1.5, 2.5, 4.0),
         key="photometric.blur_sigma"),
    Axis("jpeg_quality", "JPEG quality (100 = best)", (90, 50, 10), (95, 75, 50, 30, 10, 5),
         key="photometric.jpeg_quality"),
    Axis("slant", "slant of a single plane, degrees about the vertical", (0.0, 25.0, 50.0),
         (0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 55.0), scene=_slant),
    Axis("baseline", "baseline, metres (disparity range)", (0.05, 0.2, 0.4),
         (0.05, 0.1, 0.2, 0.3, 0.4, 0.5), key="rig.baseline"),
    Axis("occluders", "number of occluding boxes", (0, 3, 8), (0, 1, 2, 4, 8, 12),
         key="scene.occluders"),
    Axis("textureless_fraction", "image fraction covered by a textureless card",
         (0.0, 0.25, 0.5), (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6), scene=_textureless_card),
    Axis("repetitive_period", "period of vertical stripes, pixels", (16.0, 8.0, 4.0),
         (32.0, 16.0, 12.0, 8.0, 6.0, 4.0, 3.0), config=_repetitive),
    # the hazards (docs/ground-truth.md): each one changes only what the right camera sees, or
    # adds thin geometry; the ground truth stays the ideal rig's exact disparity
    Axis("specular", "specular strength of every object (Blinn-Phong, shininess 32)",
         (0.0, 0.5, 2.0), (0.0, 0.25, 0.5, 1.0, 2.0, 4.0), config=_specular),
    Axis("exposure", "right/left exposure ratio in linear light (im1E)", (0.5, 1.0, 2.0),
         (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 4.0), config=_exposure),
    Axis("lighting_change", "right view's light directions turned, degrees (im1L)",
         (0.0, 30.0, 90.0), (0.0, 15.0, 30.0, 60.0, 90.0, 135.0), config=_lighting),
    Axis("vertical_offset", "rectification error: right principal point moved down, pixels",
         (0.0, 1.0, 3.0), (0.0, 0.25, 0.5, 1.0, 2.0, 3.0, 5.0), key="rig.right_dy_px"),
    Axis("roll", "rectification error: right camera rotated about its optical axis, degrees",
         (0.0, 0.5, 2.0), (0.0, 0.25, 0.5, 1.0, 2.0, 3.0), key="rig.right_rz_deg"),
    Axis("thin_structures", "number of wire fences (bars 1-2 px wide) in front of the scene",
         (0, 1, 3), (0, 1, 2, 3, 5), scene=_fences),
):
    register_axis(_axis)
