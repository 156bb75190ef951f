"""Scene layouts that hold other objects: a furnished room, a distant backdrop, the outdoors.

They are the base presets of the dataset configs ``floating``, ``dense`` and ``outdoor``
(``src/synth/dataset/configs/``), which add their floating objects through the ``occluder_*``
keys; the layout is the seed's, the rest is data in the config.

- :func:`room`: the rig stands inside a room 4-9 m wide, 5-11 m deep and 2.4-3.6 m high, the
  cameras 1.2-1.8 m above the floor (so every view direction ahead meets a surface: floor,
  walls, ceiling). Against the walls stand 4-9 pieces of furniture (tables, chairs, shelves,
  stools, lamps: :mod:`scenes.families`); on the tops of most of them, and on the floor, lie
  3-12 smaller things (rocks, vases and bottles, polyhedra, superquadrics, tori, boxes): the
  background clutter of a lived-in room.
- :func:`backdrop`: one wall at 60 m, framed for the default rig, behind whatever a config
  puts in front of it (``dense``: up to 200 objects at 5-50 m).
- :func:`outdoor`: rolling ground (a terrain 120 x 94 m, relief 0.5-3 m) under the cameras at
  1.2-2.5 m, 6-25 trees, 6-30 bushes and 10-40 rocks standing on it at 3-60 m (each at the
  ground's height where it stands, sunk in by 5 % of its height, rocks by half), under a sky
  at infinity (:mod:`scenes.sky`: clear to overcast, blue to grey, hazy land below the
  horizon beyond the terrain; disparity 0 there).

Textures are noise at about 8 pixels per period at each object's depth, as the other presets;
a config's ``object_*`` keys redraw them per object (photographs, frequencies, contrast).
"""

from __future__ import annotations

import numpy as np

from scenes.primitives import terrain_heights
from scenes.sky import SkySpec
from scenes.spec import LightSpec, ObjectSpec, Pose, SceneSpec, TextureSpec

__all__ = ["room", "backdrop", "outdoor", "BACKDROP_DEPTH", "outdoor_sky"]

#: Depth of :func:`backdrop`'s wall, metres.
BACKDROP_DEPTH = 60.0
_FOCAL, _BASELINE, _MARGIN = 600.0, 0.1, 1.4  # the default rig the presets are framed for
_PERIOD_PX = 8.0
_SINK = 0.05  # how far what stands on the ground is sunk into it, a fraction of its height
_FRONT = 0.2  # metres ahead of the cameras where the room's floor, walls and ceiling begin
#: Kinds of the small things on furniture tops and on the floor (a repeat weighs a kind).
_CLUTTER = ("rock", "revolution", "polyhedron", "superquadric", "torus", "box", "revolution")


def _r4(x: float) -> float:
    return float(round(float(x), 4))


def _texture(rng: np.random.Generator, depth: float) -> TextureSpec:
    return TextureSpec(kind="noise", frequency=_r4(_FOCAL / (_PERIOD_PX * max(depth, 0.5))
                                                   * rng.uniform(0.8, 1.25)),
                       contrast=_r4(rng.uniform(0.4, 1.0)), mean=_r4(rng.uniform(0.3, 0.7)),
                       color=tuple(_r4(c) for c in rng.uniform(0.6, 1.0, size=3)),
                       seed=int(rng.integers(0, 2**31)), angle=_r4(rng.uniform(0.0, 180.0)))


def _surface(name: str, centre: tuple[float, float, float], rotation: tuple[float, float, float],
             size: tuple[float, float], rng: np.random.Generator, depth: float) -> ObjectSpec:
    return ObjectSpec("plane", Pose(translation=tuple(_r4(c) for c in centre),
                                    rotation_deg=rotation),
                      tuple(_r4(s) for s in size), _texture(rng, depth), name=name)


def _clutter(rng: np.random.Generator, name: str, x: float, floor_y: float, z: float,
             scale: float) -> ObjectSpec:
    """A small thing resting on the surface at height ``floor_y`` (y down), centred at x, z."""
    kind = str(rng.choice(_CLUTTER))
    if kind == "revolution":
        size = (_r4(scale * rng.uniform(0.25, 0.5)), _r4(scale * rng.uniform(0.6, 1.0)))
        half = size[1] / 2
    elif kind in ("rock", "polyhedron"):
        size = (_r4(scale * rng.uniform(0.3, 0.5)),)
        half = size[0]
    elif kind == "torus":
        size = (_r4(scale * 0.4), _r4(scale * 0.4 * rng.uniform(0.15, 0.45)))
        half = size[0] + size[1]  # lying at any angle: its bounding sphere rests there
    else:  # box, superquadric
        size = tuple(_r4(v) for v in scale * rng.uniform(0.3, 0.7, size=3))
        half = size[1] / 2
    rotation = (0.0, _r4(rng.uniform(0.0, 360.0)), 0.0)
    if kind in ("rock", "polyhedron", "torus"):
        rotation = tuple(_r4(a) for a in rng.uniform(0.0, 360.0, size=3))
    return ObjectSpec(kind, Pose(translation=(_r4(x), _r4(floor_y - half), _r4(z)),
                                 rotation_deg=rotation), size, _texture(rng, z),
                      name=name, segments=32, seed=int(rng.integers(0, 2**63)))


def room(seed: int) -> SceneSpec:
    """A furnished room around the rig (see the module docstring).

    Examples
    --------
    >>> spec = room(0)
    >>> [o.name for o in spec.objects[:5]]
    ['floor', 'ceiling', 'back_wall', 'left_wall', 'right_wall']
    >>> room(0) == room(0) != room(1)
    True
    """
    rng = np.random.default_rng(seed)
    width, depth, height = rng.uniform(4.0, 9.0), rng.uniform(5.0, 11.0), rng.uniform(2.4, 3.6)
    eye = rng.uniform(1.2, 1.8)  # cameras above the floor; y points down
    x0 = _BASELINE / 2 + rng.uniform(-0.3, 0.3) * width  # the rig need not stand in the middle
    left, right = x0 - width / 2, x0 + width / 2
    # the room's surfaces start _FRONT ahead of the cameras (nothing behind them is drawn);
    # the default rig's views meet the floor, walls and ceiling beyond 2 m
    floor_y, ceiling_y, back = eye, eye - height, depth - 1.0
    mid_y, mid_z, span = (floor_y + ceiling_y) / 2, (back + _FRONT) / 2, back - _FRONT
    objects = [
        _surface("floor", (x0, floor_y, mid_z), (-90.0, 0.0, 0.0), (width, span), rng, mid_z),
        _surface("ceiling", (x0, ceiling_y, mid_z), (90.0, 0.0, 0.0), (width, span), rng, mid_z),
        _surface("back_wall", (x0, mid_y, back), (0.0, 0.0, 0.0), (width, height), rng, back),
        _surface("left_wall", (left, mid_y, mid_z), (0.0, -90.0, 0.0), (span, height), rng,
                 mid_z),
        _surface("right_wall", (right, mid_y, mid_z), (0.0, 90.0, 0.0), (span, height), rng,
                 mid_z),
    ]
    tops = []
    for i in range(int(rng.integers(4, 10))):
        sx, sy, sz = rng.uniform(0.4, 1.6), rng.uniform(0.45, min(2.0, 0.8 * height)), \
            rng.uniform(0.35, 0.9)
        side = rng.integers(0, 3)  # 0 back wall, 1 left, 2 right
        if side == 0:
            x, z, turn = rng.uniform(left + sx, right - sx), back - sz / 2 - 0.05, 0.0
        else:
            z = rng.uniform(1.5, back - 0.5)
            x = left + sz / 2 + 0.05 if side == 1 else right - sz / 2 - 0.05
            turn = 90.0 if side == 1 else -90.0
        turn += rng.uniform(-15.0, 15.0)
        objects.append(ObjectSpec(
            "furniture", Pose(translation=(_r4(x), _r4(floor_y - sy / 2), _r4(z)),
                              rotation_deg=(0.0, _r4(turn), 0.0)),
            (_r4(sx), _r4(sy), _r4(sz)), _texture(rng, z), name=f"furniture{i}", segments=32,
            seed=int(rng.integers(0, 2**63))))
        tops.append((x, floor_y - sy, z, min(sx, sz)))
    for i, (x, top, z, span) in enumerate(tops):
        if rng.random() < 0.7:
            objects.append(_clutter(rng, f"on_furniture{i}", x, top, z, min(0.35, span)))
    for i in range(int(rng.integers(1, 6))):
        z = rng.uniform(2.0, back - 0.5)
        x = rng.uniform(left + 0.5, right - 0.5)
        objects.append(_clutter(rng, f"on_floor{i}", x, floor_y, z, rng.uniform(0.2, 0.6)))
    return SceneSpec("room", tuple(objects), seed=seed,
                     description="a furnished room around the rig: floor, walls, ceiling, "
                                 "furniture, clutter on it and on the floor")


def backdrop(seed: int) -> SceneSpec:
    """One noise wall at :data:`BACKDROP_DEPTH` covering the default rig's views.

    Examples
    --------
    >>> backdrop(0).objects[0].pose.translation
    (0.05, 0.0, 60.0)
    """
    rng = np.random.default_rng(seed)
    half_w, half_h = 320 / _FOCAL * BACKDROP_DEPTH, 240 / _FOCAL * BACKDROP_DEPTH
    size = (_r4(_MARGIN * (2 * half_w + _BASELINE)), _r4(_MARGIN * 2 * half_h * 1.2))
    wall = ObjectSpec("plane", Pose(translation=(_BASELINE / 2, 0.0, BACKDROP_DEPTH)), size,
                      _texture(rng, BACKDROP_DEPTH), name="backdrop")
    return SceneSpec("backdrop", (wall,), seed=seed,
                     description=f"one noise wall at {BACKDROP_DEPTH:g} m")


def _ground(terrain: ObjectSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World grid ``x`` (nx + 1,), ``z`` (nz + 1,) and ground ``y`` (nz + 1, nx + 1) of an
    unrotated terrain."""
    x, z, height = terrain_heights(terrain)
    tx, ty, tz = terrain.pose.translation
    return x + tx, z + tz, ty - height


def _ground_y(ground: tuple[np.ndarray, np.ndarray, np.ndarray], x: float, z: float) -> float:
    """The ground's height (its ``y``) at ``(x, z)``, bilinear over the grid cell holding it
    (within a few millimetres of its two triangles for this relief)."""
    gx, gz, gy = ground
    i = int(np.clip(np.searchsorted(gx, x) - 1, 0, len(gx) - 2))
    k = int(np.clip(np.searchsorted(gz, z) - 1, 0, len(gz) - 2))
    tx = float(np.clip((x - gx[i]) / (gx[i + 1] - gx[i]), 0.0, 1.0))
    tz = float(np.clip((z - gz[k]) / (gz[k + 1] - gz[k]), 0.0, 1.0))
    top = gy[k, i] * (1 - tx) + gy[k, i + 1] * tx
    bottom = gy[k + 1, i] * (1 - tx) + gy[k + 1, i + 1] * tx
    return float(top * (1 - tz) + bottom * tz)


def outdoor_sky(rng: np.random.Generator) -> SkySpec:
    """A day sky: clear blue to overcast grey (cloud cover U[0, 1]; the greyer the more
    overcast), a paler horizon, hazy green-grey to brown-grey land below it.

    Examples
    --------
    >>> outdoor_sky(np.random.default_rng(0)) == outdoor_sky(np.random.default_rng(0))
    True
    """
    clouds = float(rng.uniform(0.0, 1.0))
    blue = np.array([rng.uniform(0.2, 0.45), rng.uniform(0.4, 0.65), rng.uniform(0.75, 0.95)])
    grey = np.full(3, rng.uniform(0.55, 0.8))
    zenith = blue + (grey - blue) * clouds ** 2
    horizon = zenith + (np.minimum(zenith + 0.25, 1.0) - zenith) * rng.uniform(0.4, 1.0)
    land = np.array([rng.uniform(0.35, 0.55), rng.uniform(0.4, 0.6), rng.uniform(0.3, 0.5)])
    ground = land + (horizon - land) * rng.uniform(0.3, 0.7)  # haze toward the horizon
    cloud = np.full(3, rng.uniform(0.8, 1.0)) - rng.uniform(0.0, 0.3) * clouds
    return SkySpec(zenith=tuple(_r4(c) for c in zenith), horizon=tuple(_r4(c) for c in horizon),
                   ground=tuple(_r4(c) for c in ground), clouds=_r4(clouds),
                   cloud_colour=tuple(_r4(c) for c in np.clip(cloud, 0.0, 1.0)),
                   cloud_scale=_r4(rng.uniform(0.2, 1.0)), seed=int(rng.integers(0, 2**63)))


def outdoor(seed: int) -> SceneSpec:
    """Ground, trees, bushes and rocks at 3-60 m under a sky (see the module docstring).

    Examples
    --------
    >>> spec = outdoor(0)
    >>> spec.objects[0].kind, spec.sky is not None
    ('terrain', True)
    >>> outdoor(0) == outdoor(0) != outdoor(1)
    True
    """
    rng = np.random.default_rng(seed)
    eye = rng.uniform(1.2, 2.5)
    # from 0.3 m ahead (nothing behind the cameras) to 94.3 m, inside the default far plane
    terrain = ObjectSpec("terrain", Pose(translation=(_BASELINE / 2, _r4(eye), 47.3)),
                         (120.0, 94.0, _r4(rng.uniform(0.5, 3.0))), _texture(rng, 20.0),
                         name="ground", segments=96, seed=int(rng.integers(0, 2**63)))
    sky = outdoor_sky(rng)
    ground = _ground(terrain)
    objects = [terrain]
    kinds = [("tree", int(rng.integers(6, 26))), ("bush", int(rng.integers(6, 31))),
             ("rock", int(rng.integers(10, 41)))]
    for kind, count in kinds:
        for i in range(count):
            z = float(np.exp(rng.uniform(np.log(3.0), np.log(60.0))))
            x = _BASELINE / 2 + rng.uniform(-0.7, 0.7) * z
            if kind == "tree":
                size = (rng.uniform(2.0, 7.0), rng.uniform(3.0, 12.0))
            elif kind == "bush":
                size = (rng.uniform(0.5, 2.5), rng.uniform(0.4, 1.6))
            else:
                size = (rng.uniform(0.15, 1.5),)
            size = tuple(_r4(v) for v in size)
            half = size[1] / 2 if kind != "rock" else 0.5 * size[0]  # rocks sunk by half
            base = _ground_y(ground, x, z) + _SINK * size[1 if kind != "rock" else 0]
            rotation = (0.0, _r4(rng.uniform(0.0, 360.0)), 0.0)
            if kind == "rock":
                rotation = tuple(_r4(a) for a in rng.uniform(0.0, 360.0, size=3))
            objects.append(ObjectSpec(kind, Pose(translation=(_r4(x), _r4(base - half), _r4(z)),
                                                 rotation_deg=rotation),
                                      size, _texture(rng, z), name=f"{kind}{i}", segments=32,
                                      seed=int(rng.integers(0, 2**63))))
    light = LightSpec(direction=(_r4(rng.uniform(-0.6, 0.6)), 1.0, _r4(rng.uniform(0.2, 1.0))),
                      intensity=0.85, ambient=0.3)
    return SceneSpec("outdoor", tuple(objects), light=light, seed=seed, sky=sky,
                     description="ground, trees, bushes and rocks at 3-60 m under a sky")
