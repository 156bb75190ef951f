"""Scene specifications: frozen dataclasses that round-trip exactly through TOML and JSON.

A scene is data. Its world frame is the left camera's frame in OpenCV orientation (``x`` right,
``y`` down, ``z`` forward = depth, metres; see ``docs/conventions.md``). Every number survives
``load(dump(spec)) == spec`` exactly (:mod:`scenes.serialize`): floats are written with ``repr`` (shortest round-trip form)
and sequences come back as tuples.

On disk a scene is a table with the keys ``version`` (currently 1), ``name``, ``description``,
``seed``, ``background``, ``light`` (a table), ``objects`` (an array of tables, each with a
``pose``, a ``texture`` and optionally a ``material`` table) and optionally ``lamps`` (an array of
tables; see :mod:`scenes.materials`) and ``sky`` (a table: :mod:`scenes.sky`). Missing keys take
the dataclass defaults; unknown keys are an error.

The conversion to and from plain dicts, TOML, JSON and files is :mod:`scenes.serialize`: it
reads the fields of these dataclasses (``dataclasses.fields``), so a new field is written and
read without a change there; a new *nested* dataclass field needs its line in
:func:`scenes.serialize.scene_from_dict` (the round-trip property tests catch a missing one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from scenes.families import (
    FAMILY_SIZES,
    KNOT_TUBE_RATIO,
    WIRE_THICKNESS_RATIO,
    family_size_problem,
)
from scenes.materials import MAX_LAMPS, LampSpec, MaterialSpec
from scenes.skyspec import SkySpec
from stereoforge.validation import (
    check_choice,
    check_int,
    check_real,
    check_sequence,
    check_type,
    fail,
)

__all__ = [
    "TEXTURE_KINDS",
    "SKIMAGE_PHOTOS",
    "MAX_EXTENT",
    "OBJECT_KINDS",
    "FAMILY_KINDS",
    "DEFORM_LIMITS",
    "TextureSpec",
    "Pose",
    "ObjectSpec",
    "LightSpec",
    "SceneSpec",
]

#: Texture kinds understood by :func:`scenes.textures.make_texture` (``"image"``: a photograph,
#: :mod:`scenes.photos`).
TEXTURE_KINDS: tuple[str, ...] = ("noise", "checker", "stripes", "constant", "image")

#: Object kinds and the meaning of their ``size`` tuple.
OBJECT_KINDS: dict[str, tuple[str, ...]] = {
    "plane": ("width", "height"),
    "box": ("sx", "sy", "sz"),
    "sphere": ("radius",),
    "cylinder": ("radius", "height"),
    "moebius": ("radius", "width"),
    "terrain": ("width", "depth", "amplitude"),
    "fence": ("width", "height", "spacing", "thickness"),
    "grid": ("width", "height", "spacing", "thickness"),
    "mesh": ("scale",),
    # procedural families (:mod:`scenes.families`): the shape within the size is the seed's
    **FAMILY_SIZES,
}

#: The procedural families of :data:`OBJECT_KINDS`: their shape is drawn from ``seed``.
FAMILY_KINDS: tuple[str, ...] = tuple(FAMILY_SIZES)
#: What the size of a family must satisfy beyond positive values
#: (:func:`scenes.families.family_size_problem` checks it).
_FAMILY_CONDITIONS = {"torus": "tube < radius", "knot": f"tube <= {KNOT_TUBE_RATIO} * radius",
                      "wire": f"thickness <= {WIRE_THICKNESS_RATIO} * length"}

#: Bounds of :attr:`ObjectSpec.deform` ``(twist, bend, taper)``: angles in radians, taper a
#: fraction (the radius at the ends is ``1 -+ taper`` times the middle's).
DEFORM_LIMITS: tuple[float, float, float] = (2 * math.pi, math.pi, 0.9)

#: Object kinds whose ``size`` may hold zero (terrain's amplitude) -- by label.
_ZERO_SIZES = frozenset({"amplitude"})

#: Dataclass field metadata: the field is left out of :func:`scene_to_dict` while it holds its
#: default, so that scenes written before it existed keep their bytes (``scene.json``).
_OMIT_DEFAULT = {"omit_default": True}

#: Bound of every length and coordinate of a scene, metres: a size is in ``(0, MAX_EXTENT]`` and
#: each translation component in ``[-MAX_EXTENT, MAX_EXTENT]``. A kilometre-wide terrain is
#: 1e3; beyond 1e6 float32 vertices lose centimetres and GL clips or drops the geometry
#: (a plane of size 1e300 rendered as an empty image).
MAX_EXTENT = 1e6

#: Photographs shipped with scikit-image (``skimage.data.<name>()``, no download), usable as
#: ``TextureSpec(kind="image", image="skimage:<name>")``.
SKIMAGE_PHOTOS: tuple[str, ...] = (
    "astronaut", "brick", "camera", "cell", "chelsea", "clock", "coffee", "coins", "grass",
    "gravel", "hubble_deep_field", "immunohistochemistry", "moon", "page", "rocket",
    "text")
_SKIMAGE_PREFIX = "skimage:"

_MAX_SEED = 2**63  # TOML integers are signed 64-bit
_MAX_SEGMENTS = 4096


# --------------------------------------------------------------------------- coercion helpers
def _vec(value: Any, name: str, n: int | None, **bounds: Any) -> tuple[float, ...]:
    """A sequence of ``n`` finite numbers within ``bounds``, as a tuple of floats."""
    return check_sequence(value, name, length=n, of="numbers",
                          item=lambda v, item: check_real(v, item, **bounds))


def _seed(value: Any, name: str) -> int:
    return check_int(value, name, lo=0, hi=_MAX_SEED, hi_open=True)


def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


# --------------------------------------------------------------------------- dataclasses
@dataclass(frozen=True)
class TextureSpec:
    """A procedural surface texture (see :func:`scenes.textures.make_texture`).

    Parameters
    ----------
    kind : {"noise", "checker", "stripes", "constant", "image"}
        ``"noise"``: isotropic band-limited noise centred on ``frequency``. ``"checker"``: a
        checkerboard, one period = two squares. ``"stripes"``: stripes across direction ``angle``.
        ``"constant"``: textureless, grey level ``mean``. ``"image"``: the photograph ``image``
        (:mod:`scenes.photos`), scaled so that its mean spatial frequency lands on
        ``frequency``, turned by ``angle``, at an offset drawn from ``seed``.
    frequency : float
        Spatial frequency on the surface in cycles per metre, > 0 (of a photograph: its
        power-weighted mean frequency, :func:`scenes.photos.photo_frequency`).
    contrast : float
        In [0, 1]. Grey level = ``clip(mean + contrast * 0.5 * pattern, 0, 1)`` with the pattern
        in [-1, 1]; 0 gives a constant image.
    mean : float
        Mean grey level in [0, 1].
    color : (3,) tuple of float
        RGB tint in [0, 1] multiplying the grey level.
    seed : int
        Seed of the noise pattern (and the phase of checker/stripes), in [0, 2**63).
    angle : float
        Orientation in degrees of the checker, stripe and image pattern (ignored by
        noise/constant).
    image : str
        Kind ``"image"`` only (and required there): ``"skimage:<name>"`` (a photograph shipped with
        scikit-image, :data:`scenes.photos.SKIMAGE_PHOTOS`), an image file, or a folder of image
        files (one chosen by ``seed``). Paths are used as written (relative ones from the
        working directory). Checked when the texture is made (:class:`scenes.photos.AssetError`).

    Examples
    --------
    >>> TextureSpec(kind="stripes", frequency=10.0, angle=45.0).kind
    'stripes'
    """

    kind: str = "noise"
    frequency: float = 4.0
    contrast: float = 0.8
    mean: float = 0.5
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    seed: int = 0
    angle: float = 0.0
    image: str = field(default="", metadata=_OMIT_DEFAULT)

    def __post_init__(self) -> None:
        kind = check_choice(check_type(self.kind, "TextureSpec.kind", str), "TextureSpec.kind",
                            TEXTURE_KINDS)
        check_type(self.image, "TextureSpec.image", str)
        if (kind == "image") != bool(self.image):
            raise fail("TextureSpec.image", "a photograph for kind 'image', and only for it",
                       f"kind {kind!r} with image {self.image!r}",
                       fix="give image = 'skimage:brick', a file or a folder with kind 'image'"
                       if kind == "image" else "drop image, or set kind = 'image'")
        if self.image.startswith(_SKIMAGE_PREFIX):
            check_choice(self.image[len(_SKIMAGE_PREFIX):], "TextureSpec.image (skimage:<name>)",
                         SKIMAGE_PHOTOS)
        _set(self, "frequency", check_real(self.frequency, "TextureSpec.frequency", lo=0.0,
                                           lo_open=True))
        _set(self, "contrast", check_real(self.contrast, "TextureSpec.contrast", lo=0.0, hi=1.0))
        _set(self, "mean", check_real(self.mean, "TextureSpec.mean", lo=0.0, hi=1.0))
        _set(self, "color", _vec(self.color, "TextureSpec.color", 3, lo=0.0, hi=1.0))
        _set(self, "seed", _seed(self.seed, "TextureSpec.seed"))
        _set(self, "angle", check_real(self.angle, "TextureSpec.angle"))


@dataclass(frozen=True)
class Pose:
    """Rigid placement of an object's local frame in the world (left camera) frame.

    ``X_world = R @ X_local + translation`` with ``R = Rz(c) @ Ry(b) @ Rx(a)`` for
    ``rotation_deg = (a, b, c)``: extrinsic rotations in degrees about the fixed world axes, first
    ``x``, then ``y``, then ``z`` (right-handed: a positive angle turns ``y`` toward ``z`` for
    ``Rx``, ``z`` toward ``x`` for ``Ry`` and ``x`` toward ``y`` for ``Rz``).

    Parameters
    ----------
    translation : (3,) tuple of float
        Position of the local origin in metres, each component in
        ``[-MAX_EXTENT, MAX_EXTENT]`` (1e6 m).
    rotation_deg : (3,) tuple of float
        Extrinsic X, Y, Z Euler angles in degrees.

    Examples
    --------
    >>> Pose(translation=(0.0, 0.0, 2.0)).matrix()[:3, 3]
    array([0., 0., 2.])
    """

    translation: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        _set(self, "translation", _vec(self.translation, "Pose.translation", 3, lo=-MAX_EXTENT,
                                       hi=MAX_EXTENT))
        _set(self, "rotation_deg", _vec(self.rotation_deg, "Pose.rotation_deg", 3))

    def rotation(self) -> np.ndarray:
        """Rotation matrix ``R``, a (3, 3) float64 array (see the class docstring)."""
        a, b, c = np.deg2rad(self.rotation_deg)
        ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
        rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
        ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
        rz = np.array([[cc, -sc, 0.0], [sc, cc, 0.0], [0.0, 0.0, 1.0]])
        return rz @ ry @ rx

    def matrix(self) -> np.ndarray:
        """Homogeneous local-to-world transform, a (4, 4) float64 array."""
        out = np.eye(4)
        out[:3, :3] = self.rotation()
        out[:3, 3] = self.translation
        return out


@dataclass(frozen=True)
class ObjectSpec:
    """One object of a scene. Local frames (before ``pose``) and ``size`` by kind:

    - ``"plane"`` ``(width, height)``: rectangle centred at the origin in the local ``x``-``y``
      plane (width along ``x``), normal along local ``-z`` (facing the camera when unrotated).
    - ``"box"`` ``(sx, sy, sz)``: axis-aligned box centred at the origin.
    - ``"sphere"`` ``(radius,)``: centred at the origin, poles on the local ``y`` axis.
    - ``"cylinder"`` ``(radius, height)``: closed, axis along local ``y``, centred.
    - ``"moebius"`` ``(radius, width)``: centre line a circle of ``radius`` in the local
      ``x``-``y`` plane, one half-twist; ``width < 2 * radius``.
    - ``"terrain"`` ``(width, depth, amplitude)``: heightfield over the local ``x``-``z`` plane
      (width along ``x``, depth along ``z``), centred, height along local ``-y`` ("up" in the
      camera frame) in ``[-amplitude, amplitude]``. The relief is band-limited noise from
      ``seed`` (this object's geometry seed, not the texture's) with centre frequency
      ``4 / min(width, depth)`` cycles per metre.
    - ``"fence"`` ``(width, height, spacing, thickness)``: a row of vertical square bars
      (``thickness`` x ``height`` x ``thickness``) in the local ``x``-``y`` plane, centred, one
      every ``spacing`` across ``width`` (as many as fit, the row centred); a thin and repetitive
      structure. ``thickness < spacing``.
    - ``"grid"`` ``(width, height, spacing, thickness)``: the fence's vertical bars plus horizontal
      bars (``width`` x ``thickness`` x ``thickness``) one every ``spacing`` down ``height``, set
      ``thickness`` behind the vertical ones (local ``+z``) so no two faces are coplanar: a wire
      grid. ``thickness < spacing``.
    - ``"mesh"`` ``(scale,)``: the triangle mesh in the file ``path`` (OBJ, PLY, STL, GLB, ...
      through trimesh), its coordinates times ``scale``, then ``pose`` (see
      :mod:`scenes.primitives` for its texture).
    - The procedural families (:data:`FAMILY_KINDS`, built by :mod:`scenes.families`; their
      shape within the size is drawn from ``seed``): ``"superquadric"`` ``(sx, sy, sz)``,
      ``"rock"`` ``(radius,)``, ``"torus"`` ``(radius, tube)`` (``tube < radius``), ``"knot"``
      ``(radius, tube)`` (``tube <= 0.15 radius``), ``"revolution"`` ``(radius, height)``
      (vases, bottles, bowls, shades, goblets), ``"extrusion"`` ``(radius, depth)``,
      ``"polyhedron"`` ``(radius,)``, ``"tree"`` and ``"bush"`` ``(width, height)``, ``"wire"``
      ``(length, thickness)`` (``thickness <= 0.25 length``), ``"furniture"`` ``(sx, sy, sz)``
      (tables, chairs, shelves, stools, lamps standing on local ``+y``). Their tessellation
      follows ``segments`` up to 256.

    Parameters
    ----------
    kind : str
        One of the kinds above.
    pose : Pose
        Local-to-world placement.
    size : tuple of float
        Dimensions in metres, all in ``(0, MAX_EXTENT]`` (terrain amplitude may be 0).
    texture : TextureSpec
        Surface texture.
    name : str
        Optional label.
    segments : int
        Tessellation (sphere/cylinder: segments around; moebius: segments along the strip;
        terrain: cells along the longer side), in [3, 4096]; ignored by plane and box.
    seed : int
        Geometry seed (terrain relief), in [0, 2**63); ignored by the other kinds.
    material : MaterialSpec
        Specular reflectance (default matte; see :mod:`scenes.materials`). Written to a scene
        file only when not matte.
    path : str
        Kind ``"mesh"`` only (and required there): the mesh file, used as written (relative
        paths from the working directory). Loaded when the mesh is built
        (:class:`scenes.photos.AssetError` if trimesh cannot load it).
    own_texture : bool
        Kind ``"mesh"`` only: use the file's own texture (its UVs and image) when it has one,
        instead of ``texture`` on generated UVs. False by default.
    deform : (3,) tuple of float
        ``(twist, bend, taper)`` of the local shape about its ``y`` axis before ``pose`` (see
        :func:`scenes.families.deform`): twist and bend are total angles in radians over the
        object's height (at most :data:`DEFORM_LIMITS` ``2 pi`` and ``pi``), taper a fraction
        in ``[-0.9, 0.9]``. Any kind but plane and terrain; ``(0, 0, 0)`` (the default) is none,
        and is left out of a scene file.

    Examples
    --------
    >>> ObjectSpec("sphere", Pose(translation=(0.0, 0.0, 3.0)), (0.5,), TextureSpec()).size
    (0.5,)
    """

    kind: str
    pose: Pose
    size: tuple[float, ...]
    texture: TextureSpec = field(default_factory=TextureSpec)
    name: str = ""
    segments: int = 64
    seed: int = 0
    material: MaterialSpec = field(default_factory=MaterialSpec)
    path: str = field(default="", metadata=_OMIT_DEFAULT)
    own_texture: bool = field(default=False, metadata=_OMIT_DEFAULT)
    deform: tuple[float, float, float] = field(default=(0.0, 0.0, 0.0), metadata=_OMIT_DEFAULT)

    def __post_init__(self) -> None:
        check_type(self.material, "ObjectSpec.material", MaterialSpec)
        kind = check_choice(check_type(self.kind, "ObjectSpec.kind", str), "ObjectSpec.kind",
                            OBJECT_KINDS)
        check_type(self.path, "ObjectSpec.path", str)
        check_type(self.own_texture, "ObjectSpec.own_texture", bool)
        if (kind == "mesh") != bool(self.path):
            raise fail("ObjectSpec.path", "a mesh file for kind 'mesh', and only for it",
                       f"kind {kind!r} with path {self.path!r}",
                       fix="give path = 'model.obj' with kind 'mesh'" if kind == "mesh"
                       else "drop path, or set kind = 'mesh'")
        if self.own_texture and kind != "mesh":
            raise fail("ObjectSpec.own_texture", "False unless kind is 'mesh'",
                       f"True for a {kind}", fix="drop own_texture")
        check_type(self.pose, "ObjectSpec.pose", Pose)
        check_type(self.texture, "ObjectSpec.texture", TextureSpec)
        check_type(self.name, "ObjectSpec.name", str)
        labels = OBJECT_KINDS[kind]
        size = _vec(self.size, f"ObjectSpec.size of a {kind} {labels}", len(labels))
        for i, (label, value) in enumerate(zip(labels, size)):
            check_real(value, f"ObjectSpec.size[{i}] ({label} of a {kind})", lo=0.0,
                       lo_open=label not in _ZERO_SIZES, hi=MAX_EXTENT,
                       fix=f"sizes are metres, at most MAX_EXTENT = {MAX_EXTENT:g}")
        if kind == "moebius" and not size[1] < 2 * size[0]:
            raise fail("ObjectSpec.size of a moebius ('radius', 'width')", "width < 2 * radius",
                       repr(size), fix="narrow the strip: a wider one self-intersects")
        if kind in ("fence", "grid") and not size[3] < size[2]:
            raise fail(f"ObjectSpec.size of a {kind} {labels}", "thickness < spacing",
                       repr(size), fix="thinner bars or a wider spacing: the bars would merge")
        if kind in FAMILY_SIZES and family_size_problem(kind, size) is not None:
            raise fail(f"ObjectSpec.size of a {kind} {labels}", _FAMILY_CONDITIONS[kind],
                       repr(size), fix="a thinner tube or cable: a thicker one meets itself")
        _set(self, "size", size)
        deform = _vec(self.deform, "ObjectSpec.deform (twist, bend, taper)", 3)
        for value, limit, label in zip(deform, DEFORM_LIMITS, ("twist", "bend", "taper")):
            check_real(value, f"ObjectSpec.deform {label}", lo=-limit, hi=limit,
                       fix="twist within 2 pi, bend within pi radians, taper within 0.9")
        if any(deform) and kind in ("plane", "terrain"):
            raise fail("ObjectSpec.deform", "(0, 0, 0) for a plane or terrain", repr(deform),
                       fix="drop deform: a deformed plane is no longer a plane")
        _set(self, "deform", deform)
        _set(self, "segments", check_int(self.segments, "ObjectSpec.segments", lo=3,
                                         hi=_MAX_SEGMENTS))
        _set(self, "seed", _seed(self.seed, "ObjectSpec.seed"))


@dataclass(frozen=True)
class LightSpec:
    """One directional light plus ambient light.

    Parameters
    ----------
    direction : (3,) tuple of float
        Direction the light travels (from the light toward the scene), world frame (y down, so a
        positive y component lights from above), non-zero;
        stored as given, see :meth:`unit_direction`.
    intensity : float
        Directional intensity, >= 0.
    ambient : float
        Ambient intensity, >= 0.

    Examples
    --------
    >>> round(float(np.linalg.norm(LightSpec().unit_direction())), 12)
    1.0
    """

    direction: tuple[float, float, float] = (0.3, 0.5, 1.0)
    intensity: float = 0.8
    ambient: float = 0.35

    def __post_init__(self) -> None:
        direction = _vec(self.direction, "LightSpec.direction", 3)
        if not 0.0 < math.hypot(*direction) < math.inf:
            raise fail("LightSpec.direction", "a finite non-zero length", repr(direction),
                       fix="give a direction such as (0.3, 0.5, 1.0)")
        _set(self, "direction", direction)
        _set(self, "intensity", check_real(self.intensity, "LightSpec.intensity", lo=0.0))
        _set(self, "ambient", check_real(self.ambient, "LightSpec.ambient", lo=0.0))

    def unit_direction(self) -> np.ndarray:
        """The light direction normalised to unit length, a (3,) float64 array."""
        d = np.asarray(self.direction, dtype=np.float64)
        return d / math.hypot(*self.direction)


@dataclass(frozen=True)
class SceneSpec:
    """A whole scene: objects, light and background, in the left camera's frame.

    Parameters
    ----------
    name : str
        Scene name.
    objects : tuple of ObjectSpec
        At least one object.
    light : LightSpec
        Lighting.
    background : (3,) tuple of float
        RGB in [0, 1] where no object is hit.
    seed : int
        Seed for anything random downstream (e.g. sensor noise) and provenance; in [0, 2**63).
        Textures and terrain carry their own seeds.
    description : str
        Free text.
    lamps : tuple of LampSpec
        Lights added to ``light`` (at most ``MAX_LAMPS``; default none). A scene with lamps or a
        specular material is rendered lit (:mod:`scenes.materials`). Written to a scene file
        only when not empty.
    sky : SkySpec or None
        A sky at infinity where no object is hit, in place of ``background`` (disparity 0
        there: :mod:`scenes.sky`); written to a scene file only when set.

    Examples
    --------
    >>> plane = ObjectSpec("plane", Pose(translation=(0.0, 0.0, 2.0)), (3.0, 2.0), TextureSpec())
    >>> spec = SceneSpec("demo", (plane,))
    >>> from scenes.serialize import dumps_json, loads_json
    >>> loads_json(dumps_json(spec)) == spec
    True
    """

    name: str
    objects: tuple[ObjectSpec, ...]
    light: LightSpec = field(default_factory=LightSpec)
    background: tuple[float, float, float] = (0.0, 0.0, 0.0)
    seed: int = 0
    description: str = ""
    lamps: tuple[LampSpec, ...] = ()
    sky: SkySpec | None = None

    def __post_init__(self) -> None:
        check_type(self.name, "SceneSpec.name", str)
        if self.sky is not None:
            check_type(self.sky, "SceneSpec.sky", SkySpec)
        lamps = check_sequence(self.lamps, "SceneSpec.lamps", of="LampSpec",
                               item=lambda lamp, name: check_type(lamp, name, LampSpec))
        if len(lamps) > MAX_LAMPS:
            raise fail("SceneSpec.lamps", f"at most {MAX_LAMPS} lamps", str(len(lamps)),
                       fix="merge lamps or drop some")
        _set(self, "lamps", lamps)
        check_type(self.description, "SceneSpec.description", str)
        objects = check_sequence(self.objects, "SceneSpec.objects", of="ObjectSpec",
                                 item=lambda obj, name: check_type(obj, name, ObjectSpec))
        if not objects:
            raise fail("SceneSpec.objects", "at least one ObjectSpec", "none")
        _set(self, "objects", objects)
        check_type(self.light, "SceneSpec.light", LightSpec)
        _set(self, "background", _vec(self.background, "SceneSpec.background", 3, lo=0.0, hi=1.0))
        _set(self, "seed", _seed(self.seed, "SceneSpec.seed"))

    def is_lit(self) -> bool:
        """True when the scene needs per-fragment lighting: a lamp or a specular material."""
        return bool(self.lamps) or any(not o.material.is_matte() for o in self.objects)

    def has_specular(self) -> bool:
        """True when an object has a specular term (the pair gets highlight masks)."""
        return any(not o.material.is_matte() for o in self.objects)
