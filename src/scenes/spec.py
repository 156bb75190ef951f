"""Scene specifications: frozen dataclasses that round-trip exactly through TOML and JSON.

A scene is data. Its world frame is the left camera's frame in OpenCV orientation (``x`` right,
``y`` down, ``z`` forward = depth, metres; see ``docs/conventions.md``). Every number survives
``load(dump(spec)) == spec`` exactly: floats are written with ``repr`` (shortest round-trip form)
and sequences come back as tuples.

On disk a scene is a table with the keys ``version`` (currently 1), ``name``, ``description``,
``seed``, ``background``, ``light`` (a table) and ``objects`` (an array of tables, each with a
``pose`` and a ``texture`` table). Missing keys take the dataclass defaults; unknown keys are an
error.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import MISSING, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

__all__ = [
    "TEXTURE_KINDS",
    "OBJECT_KINDS",
    "TextureSpec",
    "Pose",
    "ObjectSpec",
    "LightSpec",
    "SceneSpec",
    "scene_to_dict",
    "scene_from_dict",
    "dumps_json",
    "loads_json",
    "dumps_toml",
    "loads_toml",
    "dump_scene",
    "load_scene",
]

#: Texture kinds understood by :func:`scenes.textures.make_texture`.
TEXTURE_KINDS: tuple[str, ...] = ("noise", "checker", "stripes", "constant")

#: Object kinds and the meaning of their ``size`` tuple.
OBJECT_KINDS: dict[str, tuple[str, ...]] = {
    "plane": ("width", "height"),
    "box": ("sx", "sy", "sz"),
    "sphere": ("radius",),
    "cylinder": ("radius", "height"),
    "moebius": ("radius", "width"),
    "terrain": ("width", "depth", "amplitude"),
}

_FORMAT_VERSION = 1
_MAX_SEED = 2**63  # TOML integers are signed 64-bit
_MAX_SEGMENTS = 4096


# --------------------------------------------------------------------------- coercion helpers
def _float(value: Any, name: str, *, lo: float | None = None, hi: float | None = None,
           lo_open: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {out!r}")
    if lo is not None and (out <= lo if lo_open else out < lo):
        rel = ">" if lo_open else ">="
        raise ValueError(f"{name} must be {rel} {lo}, got {out!r}")
    if hi is not None and out > hi:
        raise ValueError(f"{name} must be <= {hi}, got {out!r}")
    return out


def _int(value: Any, name: str, *, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    out = int(value)
    if not lo <= out < hi:
        raise ValueError(f"{name} must be in [{lo}, {hi}), got {out}")
    return out


def _str(value: Any, name: str) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a str, got {type(value).__name__} {value!r}")
    return value


def _vec(value: Any, name: str, n: int | None, **bounds: Any) -> tuple[float, ...]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise TypeError(f"{name} must be a sequence of numbers, got {type(value).__name__}")
    if n is not None and len(value) != n:
        raise ValueError(f"{name} must have {n} entries, got {len(value)}: {tuple(value)!r}")
    return tuple(_float(v, f"{name}[{i}]", **bounds) for i, v in enumerate(value))


def _set(obj: Any, name: str, value: Any) -> None:
    object.__setattr__(obj, name, value)


# --------------------------------------------------------------------------- dataclasses
@dataclass(frozen=True)
class TextureSpec:
    """A procedural surface texture (see :func:`scenes.textures.make_texture`).

    Parameters
    ----------
    kind : {"noise", "checker", "stripes", "constant"}
        ``"noise"``: isotropic band-limited noise centred on ``frequency``. ``"checker"``: a
        checkerboard, one period = two squares. ``"stripes"``: stripes across direction ``angle``.
        ``"constant"``: textureless, grey level ``mean``.
    frequency : float
        Spatial frequency on the surface in cycles per metre, > 0.
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
        Orientation in degrees of the checker and stripe pattern (ignored by noise/constant).

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

    def __post_init__(self) -> None:
        kind = _str(self.kind, "TextureSpec.kind")
        if kind not in TEXTURE_KINDS:
            raise ValueError(f"TextureSpec.kind must be one of {list(TEXTURE_KINDS)}, got {kind!r}")
        _set(self, "frequency", _float(self.frequency, "TextureSpec.frequency", lo=0.0,
                                       lo_open=True))
        _set(self, "contrast", _float(self.contrast, "TextureSpec.contrast", lo=0.0, hi=1.0))
        _set(self, "mean", _float(self.mean, "TextureSpec.mean", lo=0.0, hi=1.0))
        _set(self, "color", _vec(self.color, "TextureSpec.color", 3, lo=0.0, hi=1.0))
        _set(self, "seed", _int(self.seed, "TextureSpec.seed", lo=0, hi=_MAX_SEED))
        _set(self, "angle", _float(self.angle, "TextureSpec.angle"))


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
        Position of the local origin in metres.
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
        _set(self, "translation", _vec(self.translation, "Pose.translation", 3))
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

    Parameters
    ----------
    kind : str
        One of the kinds above.
    pose : Pose
        Local-to-world placement.
    size : tuple of float
        Dimensions in metres, all > 0 (terrain amplitude >= 0).
    texture : TextureSpec
        Surface texture.
    name : str
        Optional label.
    segments : int
        Tessellation (sphere/cylinder: segments around; moebius: segments along the strip;
        terrain: cells along the longer side), in [3, 4096]; ignored by plane and box.
    seed : int
        Geometry seed (terrain relief), in [0, 2**63); ignored by the other kinds.

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

    def __post_init__(self) -> None:
        kind = _str(self.kind, "ObjectSpec.kind")
        if kind not in OBJECT_KINDS:
            raise ValueError(f"ObjectSpec.kind must be one of {list(OBJECT_KINDS)}, got {kind!r}")
        if not isinstance(self.pose, Pose):
            raise TypeError(f"ObjectSpec.pose must be a Pose, got {type(self.pose).__name__}")
        if not isinstance(self.texture, TextureSpec):
            raise TypeError(
                f"ObjectSpec.texture must be a TextureSpec, got {type(self.texture).__name__}")
        _str(self.name, "ObjectSpec.name")
        labels = OBJECT_KINDS[kind]
        size = _vec(self.size, f"ObjectSpec.size of a {kind} {labels}", len(labels))
        for label, value in zip(labels, size):
            if value < 0 or (value == 0 and label != "amplitude"):
                note = " (amplitude >= 0)" if kind == "terrain" else ""
                raise ValueError(f"ObjectSpec.size: {kind} {label} must be > 0{note}, "
                                 f"got {value!r}")
        if kind == "moebius" and not size[1] < 2 * size[0]:
            raise ValueError(f"ObjectSpec.size: moebius width must be < 2 * radius "
                             f"(else the strip self-intersects), got {size!r}")
        _set(self, "size", size)
        _set(self, "segments", _int(self.segments, "ObjectSpec.segments", lo=3,
                                    hi=_MAX_SEGMENTS + 1))
        _set(self, "seed", _int(self.seed, "ObjectSpec.seed", lo=0, hi=_MAX_SEED))


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
            raise ValueError(
                f"LightSpec.direction must have a finite non-zero length, got {direction}; "
                "give a direction such as (0.3, 0.5, 1.0)"
            )
        _set(self, "direction", direction)
        _set(self, "intensity", _float(self.intensity, "LightSpec.intensity", lo=0.0))
        _set(self, "ambient", _float(self.ambient, "LightSpec.ambient", lo=0.0))

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

    Examples
    --------
    >>> plane = ObjectSpec("plane", Pose(translation=(0.0, 0.0, 2.0)), (3.0, 2.0), TextureSpec())
    >>> spec = SceneSpec("demo", (plane,))
    >>> loads_json(dumps_json(spec)) == spec
    True
    """

    name: str
    objects: tuple[ObjectSpec, ...]
    light: LightSpec = field(default_factory=LightSpec)
    background: tuple[float, float, float] = (0.0, 0.0, 0.0)
    seed: int = 0
    description: str = ""

    def __post_init__(self) -> None:
        _str(self.name, "SceneSpec.name")
        _str(self.description, "SceneSpec.description")
        if isinstance(self.objects, (str, bytes)) or not hasattr(self.objects, "__len__"):
            raise TypeError("SceneSpec.objects must be a sequence of ObjectSpec")
        objects = tuple(self.objects)
        if not objects:
            raise ValueError("SceneSpec.objects must hold at least one ObjectSpec, got none")
        for i, obj in enumerate(objects):
            if not isinstance(obj, ObjectSpec):
                raise TypeError(f"SceneSpec.objects[{i}] must be an ObjectSpec, "
                                f"got {type(obj).__name__}")
        _set(self, "objects", objects)
        if not isinstance(self.light, LightSpec):
            raise TypeError(f"SceneSpec.light must be a LightSpec, got {type(self.light).__name__}")
        _set(self, "background", _vec(self.background, "SceneSpec.background", 3, lo=0.0, hi=1.0))
        _set(self, "seed", _int(self.seed, "SceneSpec.seed", lo=0, hi=_MAX_SEED))


# --------------------------------------------------------------------------- dict conversion
def _to_plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_to_plain(v) for v in value]
    if hasattr(value, "__dataclass_fields__"):
        return {f.name: _to_plain(getattr(value, f.name)) for f in fields(value)}
    return value


def scene_to_dict(spec: SceneSpec) -> dict[str, Any]:
    """Plain nested dict (lists, no tuples) of a scene, ready for TOML or JSON.

    Examples
    --------
    >>> plane = ObjectSpec("plane", Pose(), (1.0, 1.0), TextureSpec())
    >>> sorted(scene_to_dict(SceneSpec("s", (plane,))))[:3]
    ['background', 'description', 'light']
    """
    if not isinstance(spec, SceneSpec):
        raise TypeError(f"spec must be a SceneSpec, got {type(spec).__name__}")
    out = {"version": _FORMAT_VERSION}
    out.update(_to_plain(spec))
    return out


def _take(data: Any, cls: type, where: str) -> dict[str, Any]:
    """Check ``data`` is a mapping whose keys are fields of ``cls``; return a copy."""
    if not isinstance(data, dict):
        raise TypeError(f"{where} must be a table/object, got {type(data).__name__}")
    valid = [f.name for f in fields(cls)]
    for key in data:
        if key not in valid:
            raise ValueError(f"unknown key {key!r} in {where}; valid keys: {valid}")
    return dict(data)


def _build(cls: type, kwargs: dict[str, Any], where: str) -> Any:
    required = [f.name for f in fields(cls)
                if f.default is MISSING and f.default_factory is MISSING]
    missing = [name for name in required if name not in kwargs]
    if missing:
        raise ValueError(f"{where} is missing the required key(s) {missing}; "
                         f"required keys: {required}")
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise TypeError(f"{where}: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def scene_from_dict(data: dict[str, Any]) -> SceneSpec:
    """Build a :class:`SceneSpec` from the nested dict written by :func:`scene_to_dict`.

    Raises
    ------
    ValueError
        On an unknown key (naming it, where it is and the valid keys), a missing required key, an
        unknown kind or an out-of-range value.
    TypeError
        On a value of the wrong type.

    Examples
    --------
    >>> scene_from_dict({"name": "s", "objects": [{"kind": "sphere", "size": [1.0],
    ...                  "pose": {"translation": [0.0, 0.0, 5.0]}}]}).objects[0].size
    (1.0,)
    """
    data = dict(data) if isinstance(data, dict) else data
    if isinstance(data, dict):
        version = data.pop("version", _FORMAT_VERSION)
        if version != _FORMAT_VERSION:
            raise ValueError(f"unsupported scene format version {version!r}; "
                             f"this stereoforge reads version {_FORMAT_VERSION}")
    top = _take(data, SceneSpec, "scene")
    raw_objects = top.get("objects", [])
    if not isinstance(raw_objects, (list, tuple)):
        raise TypeError("scene.objects must be an array of tables, "
                        f"got {type(raw_objects).__name__}")
    objects = []
    for i, raw in enumerate(raw_objects):
        where = f"objects[{i}]"
        kw = _take(raw, ObjectSpec, where)
        kw["pose"] = _build(Pose, _take(kw.get("pose", {}), Pose, f"{where}.pose"), f"{where}.pose")
        kw["texture"] = _build(TextureSpec, _take(kw.get("texture", {}), TextureSpec,
                                                  f"{where}.texture"), f"{where}.texture")
        objects.append(_build(ObjectSpec, kw, where))
    top["objects"] = tuple(objects)
    if "light" in top:
        top["light"] = _build(LightSpec, _take(top["light"], LightSpec, "scene.light"),
                              "scene.light")
    return _build(SceneSpec, top, "scene")


# --------------------------------------------------------------------------- text formats
def dumps_json(spec: SceneSpec) -> str:
    """JSON text of a scene (floats in shortest round-trip form)."""
    return json.dumps(scene_to_dict(spec), indent=2) + "\n"


def loads_json(text: str) -> SceneSpec:
    """Scene from JSON text written by :func:`dumps_json`."""
    return scene_from_dict(json.loads(text))


def dumps_toml(spec: SceneSpec) -> str:
    """TOML text of a scene (floats in shortest round-trip form)."""
    return tomli_w.dumps(scene_to_dict(spec))


def loads_toml(text: str) -> SceneSpec:
    """Scene from TOML text written by :func:`dumps_toml`."""
    return scene_from_dict(tomllib.loads(text))


_FORMATS = {".json": (dumps_json, loads_json), ".toml": (dumps_toml, loads_toml)}


def _format(path: Path) -> tuple[Any, Any]:
    try:
        return _FORMATS[path.suffix.lower()]
    except KeyError:
        raise ValueError(f"scene file {str(path)!r} must end in one of {sorted(_FORMATS)}, "
                         f"got suffix {path.suffix!r}") from None


def dump_scene(spec: SceneSpec, path: str | Path) -> Path:
    """Write a scene to ``path``; the format (TOML or JSON) follows the suffix.

    Returns
    -------
    path : pathlib.Path
        The file written.
    """
    path = Path(path)
    dumps, _ = _format(path)
    path.write_text(dumps(spec), encoding="utf-8")
    return path


def load_scene(path: str | Path) -> SceneSpec:
    """Read a scene written by :func:`dump_scene` (format by suffix: ``.toml`` or ``.json``)."""
    path = Path(path)
    _, loads = _format(path)
    return loads(path.read_text(encoding="utf-8"))
