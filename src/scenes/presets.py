"""Named scenes, framed for the default rig.

Every preset is framed for a rectified rig of 640 x 480 pixels, ``fx = fy = 600``,
``(cx, cy) = (319.5, 239.5)`` and a 0.1 m baseline: all geometry lies between 1 and 40 m in
depth, and a background wall (or the plane itself) fills the view of both cameras with a 40 %
margin, so every pixel sees geometry. Noise textures are tuned to about 8 image pixels per period
at the object's depth (``frequency = 75 / z`` cycles per metre). ``seed`` changes every texture
(and, for ``flying``, the layout); the same seed always gives the same :class:`SceneSpec`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from scenes.layouts import backdrop, outdoor, room
from scenes.spec import LightSpec, ObjectSpec, Pose, SceneSpec, TextureSpec

__all__ = ["Preset", "PRESETS", "get_preset", "list_presets", "frame_cover_size"]

# Default rig the presets are framed for.
_WIDTH, _HEIGHT, _FOCAL, _BASELINE = 640, 480, 600.0, 0.1
_MARGIN = 1.4
_IMAGE_PERIOD_PX = 8.0


def frame_cover_size(depth: float, *, margin: float = _MARGIN) -> tuple[float, float]:
    """Size ``(width, height)`` in metres of a fronto-parallel plane at ``depth`` that covers
    the default rig's two views, times ``margin``. Centre it at ``x = baseline / 2 = 0.05``.

    Examples
    --------
    >>> [round(s, 3) for s in frame_cover_size(3.0, margin=1.0)]
    [3.3, 2.4]
    """
    half_w = (_WIDTH / 2) / _FOCAL * depth
    half_h = (_HEIGHT / 2) / _FOCAL * depth
    return (margin * (2 * half_w + _BASELINE), margin * 2 * half_h)


def _freq(depth: float) -> float:
    """Texture frequency (cycles/m) giving ``_IMAGE_PERIOD_PX`` image pixels per period."""
    return round(_FOCAL / (_IMAGE_PERIOD_PX * depth), 3)


def _seeds(seed: int, n: int) -> list[int]:
    return [int(s) for s in np.random.default_rng(seed).integers(0, 2**31, size=n)]


def _wall(depth: float, seed: int, *, kind: str = "noise", mean: float = 0.5,
          name: str = "wall") -> ObjectSpec:
    return ObjectSpec("plane", Pose(translation=(_BASELINE / 2, 0.0, depth)),
                      frame_cover_size(depth),
                      TextureSpec(kind=kind, frequency=_freq(depth), contrast=0.8, mean=mean,
                                  seed=seed), name=name)


def _noise(depth: float, seed: int, **kw: float) -> TextureSpec:
    return TextureSpec(kind="noise", frequency=_freq(depth), seed=seed, **kw)


# --------------------------------------------------------------------------- builders
def _fronto_plane(seed: int) -> SceneSpec:
    return SceneSpec("fronto_plane", (_wall(2.0, _seeds(seed, 1)[0], name="plane"),),
                     seed=seed, description=PRESETS["fronto_plane"].description)


def _slanted_plane(seed: int) -> SceneSpec:
    # The plane through (0.05, 0, 2.5) turned by Ry(30) Rx(10); its centre is moved within the
    # plane toward the far side, which needs more surface to cover the view.
    plane = ObjectSpec("plane", Pose(translation=(-0.6012, 0.1773, 2.9121),
                                     rotation_deg=(10.0, 30.0, 0.0)),
                       (5.6, 4.2), _noise(3.0, _seeds(seed, 1)[0]), name="plane")
    return SceneSpec("slanted_plane", (plane,), seed=seed,
                     description=PRESETS["slanted_plane"].description)


def _boxes(seed: int) -> SceneSpec:
    s = _seeds(seed, 5)
    layout = [  # (centre, size, rotation)
        ((-0.6, 0.3, 2.5), (0.5, 0.5, 0.5), (0.0, 25.0, 0.0)),
        ((0.5, -0.25, 3.0), (0.6, 0.4, 0.4), (15.0, -30.0, 10.0)),
        ((0.1, 0.55, 2.0), (0.4, 0.3, 0.3), (0.0, 45.0, 0.0)),
        ((0.9, 0.5, 3.8), (0.5, 0.8, 0.5), (0.0, 10.0, 0.0)),
    ]
    boxes = tuple(
        ObjectSpec("box", Pose(translation=c, rotation_deg=r), size,
                   _noise(c[2], s[i], mean=0.45 + 0.05 * i), name=f"box{i}")
        for i, (c, size, r) in enumerate(layout))
    return SceneSpec("boxes", (*boxes, _wall(5.0, s[4])), seed=seed,
                     description=PRESETS["boxes"].description)


def _moebius(seed: int) -> SceneSpec:
    s = _seeds(seed, 2)
    strip = ObjectSpec("moebius", Pose(translation=(0.05, 0.0, 2.0),
                                       rotation_deg=(25.0, 35.0, 0.0)),
                       (0.55, 0.35), _noise(2.0, s[0]), name="moebius", segments=128)
    return SceneSpec("moebius", (strip, _wall(4.0, s[1])), seed=seed,
                     description=PRESETS["moebius"].description)


def _textureless(seed: int) -> SceneSpec:
    box = ObjectSpec("box", Pose(translation=(0.05, 0.0, 2.5), rotation_deg=(20.0, 35.0, 0.0)),
                     (0.8, 0.6, 0.6), TextureSpec(kind="constant", mean=0.3), name="box")
    wall = _wall(4.0, 0, kind="constant", mean=0.6)
    return SceneSpec("textureless", (box, wall), seed=seed,
                     description=PRESETS["textureless"].description)


def _flying(seed: int) -> SceneSpec:
    rng = np.random.default_rng(seed)
    wall_depth = 10.0

    def r4(x: float) -> float:
        return float(round(float(x), 4))

    objects = []
    for i in range(int(rng.integers(6, 11))):
        kind = str(rng.choice(["box", "sphere", "cylinder"]))
        z = rng.uniform(2.0, 7.0)
        x = rng.uniform(-0.4, 0.4) * z + _BASELINE / 2
        y = rng.uniform(-0.3, 0.3) * z
        scale = rng.uniform(0.08, 0.2) * z  # bounding radius <= sqrt(3) * scale <= 0.35 z
        if kind == "box":
            size = tuple(r4(v) for v in rng.uniform(1.0, 2.0, size=3) * scale)
        elif kind == "sphere":
            size = (r4(scale),)
        else:
            size = (r4(rng.uniform(0.4, 0.8) * scale), r4(rng.uniform(1.0, 2.0) * scale))
        tex_kind = str(rng.choice(["noise", "noise", "noise", "checker", "stripes"]))
        texture = TextureSpec(kind=tex_kind, frequency=r4(_freq(z) * rng.uniform(0.8, 1.25)),
                              contrast=r4(rng.uniform(0.5, 1.0)), mean=r4(rng.uniform(0.35, 0.65)),
                              color=tuple(r4(c) for c in rng.uniform(0.6, 1.0, size=3)),
                              seed=int(rng.integers(0, 2**31)), angle=r4(rng.uniform(0.0, 180.0)))
        pose = Pose(translation=(r4(x), r4(y), r4(z)),
                    rotation_deg=tuple(r4(a) for a in rng.uniform(0.0, 360.0, size=3)))
        objects.append(ObjectSpec(kind, pose, size, texture, name=f"{kind}{i}", segments=32))
    wall = _wall(wall_depth, int(rng.integers(0, 2**31)))
    return SceneSpec("flying", (*objects, wall), seed=seed,
                     description=PRESETS["flying"].description)


def _terrain(seed: int) -> SceneSpec:
    s = _seeds(seed, 3)
    ground = ObjectSpec("terrain", Pose(translation=(_BASELINE / 2, 1.5, 16.5)), (30.0, 30.0, 0.35),
                        _noise(15.0, s[0]), name="terrain", segments=48, seed=s[1])
    light = LightSpec(direction=(0.4, 1.0, 0.6))
    return SceneSpec("terrain", (ground, _wall(36.0, s[2])), light=light, seed=seed,
                     description=PRESETS["terrain"].description)


# --------------------------------------------------------------------------- registry
@dataclass(frozen=True)
class Preset:
    """A named scene recipe.

    Parameters
    ----------
    name : str
        Registry key.
    description : str
        One line.
    builder : callable
        ``builder(seed) -> SceneSpec``; call :meth:`build` instead.
    """

    name: str
    description: str
    builder: Callable[[int], SceneSpec]

    def build(self, *, seed: int = 0) -> SceneSpec:
        """The preset's :class:`SceneSpec` for ``seed`` (an int in [0, 2**63))."""
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
            raise TypeError(f"seed must be an int, got {type(seed).__name__} {seed!r}")
        if not 0 <= seed < 2**63:
            raise ValueError(f"seed must be in [0, 2**63), got {seed}")
        return self.builder(int(seed))


PRESETS: Mapping[str, Preset] = MappingProxyType({p.name: p for p in [
    Preset("fronto_plane", "one noise-textured plane parallel to the image plane at z = 2 m",
           _fronto_plane),
    Preset("slanted_plane", "one noise-textured plane turned 30 deg about y and 10 deg about x "
           "through z = 2.5 m", _slanted_plane),
    Preset("boxes", "four noise-textured boxes at 2-4 m in front of a wall at 5 m", _boxes),
    Preset("moebius", "a noise-textured Moebius strip at 2 m in front of a wall at 4 m", _moebius),
    Preset("textureless", "a constant grey box at 2.5 m in front of a lighter constant wall "
           "at 4 m", _textureless),
    Preset("flying", "6-10 random boxes, spheres and cylinders (layout from the seed) at 2-7 m "
           "in front of a wall at 10 m", _flying),
    Preset("terrain", "a noise heightfield 1.5 m below the camera from 1.5 to 31.5 m, seen at "
           "a grazing angle, wall at 36 m", _terrain),
    Preset("room", "a furnished room around the rig (4-9 m wide, 5-11 m deep): floor, walls, "
           "ceiling, 4-9 pieces of furniture and clutter on them and on the floor", room),
    Preset("backdrop", "one noise wall at 60 m, for configs that put their objects in front",
           backdrop),
    Preset("outdoor", "rolling ground under the rig, 6-25 trees, 6-30 bushes and 10-40 rocks "
           "on it at 3-60 m, a distant bluish backdrop at 95 m", outdoor),
]})


def list_presets() -> list[tuple[str, str]]:
    """``(name, description)`` of every preset, in registry order.

    Examples
    --------
    >>> list_presets()[0][0]
    'fronto_plane'
    """
    return [(p.name, p.description) for p in PRESETS.values()]


def get_preset(name: str, *, seed: int = 0) -> SceneSpec:
    """The :class:`SceneSpec` of preset ``name`` for ``seed``.

    Raises
    ------
    ValueError
        If ``name`` is not a preset (the message lists the valid ones).

    Examples
    --------
    >>> spec = get_preset("fronto_plane", seed=1)
    >>> spec.objects[0].kind, spec.objects[0].pose.translation
    ('plane', (0.05, 0.0, 2.0))
    """
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; valid presets: {', '.join(PRESETS)}")
    return PRESETS[name].build(seed=seed)
