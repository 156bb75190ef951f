"""Scenes as plain dicts, TOML, JSON and files: the exact round trip of :mod:`scenes.spec`.

``load(dump(spec)) == spec`` for every scene: floats are written with ``repr`` (shortest
round-trip form) and sequences come back as tuples. On disk a scene is a table with the keys
``version`` (currently 1), ``name``, ``description``, ``seed``, ``background``, ``light`` (a
table), ``objects`` (an array of tables, each with a ``pose``, a ``texture`` and optionally a
``material`` table) and optionally ``lamps`` (an array of tables; see :mod:`scenes.materials`)
and ``sky`` (a table: :mod:`scenes.sky`). Missing keys take the dataclass defaults; unknown keys are an error naming the key, where it is
and the valid keys. The dataclasses' own fields drive both directions.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import MISSING, fields
from pathlib import Path
from typing import Any

import tomli_w

from scenes.materials import LampSpec, MaterialSpec
from scenes.skyspec import SkySpec
from scenes.spec import LightSpec, ObjectSpec, Pose, SceneSpec, TextureSpec
from stereoforge.errors import SceneError, StereoforgeError
from stereoforge.validation import check_keys, check_text, check_type, fail

__all__ = ["scene_to_dict", "scene_from_dict", "dumps_json", "loads_json", "dumps_toml",
           "loads_toml", "dump_scene", "load_scene"]

_FORMAT_VERSION = 1

# --------------------------------------------------------------------------- dict conversion
#: Fields written only when they differ from their default, so that the scene files (and the
#: ``scene.json`` of every pair) of scenes that do not use them keep their bytes.
_WRITTEN_IF_SET = {(ObjectSpec, "material"): MaterialSpec(), (SceneSpec, "lamps"): (),
                   (SceneSpec, "sky"): None}


def _to_plain(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_to_plain(v) for v in value]
    if hasattr(value, "__dataclass_fields__"):
        return {f.name: _to_plain(getattr(value, f.name)) for f in fields(value)
                if not ((type(value), f.name) in _WRITTEN_IF_SET
                        and getattr(value, f.name) == _WRITTEN_IF_SET[type(value), f.name])
                and not (f.metadata.get("omit_default") and getattr(value, f.name) == f.default)}
    return value


def scene_to_dict(spec: SceneSpec) -> dict[str, Any]:
    """Plain nested dict (lists, no tuples) of a scene, ready for TOML or JSON.

    Examples
    --------
    >>> plane = ObjectSpec("plane", Pose(), (1.0, 1.0), TextureSpec())
    >>> sorted(scene_to_dict(SceneSpec("s", (plane,))))[:3]
    ['background', 'description', 'light']
    """
    check_type(spec, "spec", SceneSpec)
    out = {"version": _FORMAT_VERSION}
    out.update(_to_plain(spec))
    return out


def _take(data: Any, cls: type, where: str) -> dict[str, Any]:
    """Check ``data`` is a mapping whose keys are fields of ``cls``; return a copy."""
    check_type(data, where, dict, expected="a table/object")
    check_keys(data, where, [f.name for f in fields(cls)], error=SceneError)
    return dict(data)


def _build(cls: type, kwargs: dict[str, Any], where: str) -> Any:
    required = [f.name for f in fields(cls)
                if f.default is MISSING and f.default_factory is MISSING]
    missing = [name for name in required if name not in kwargs]
    if missing:
        raise SceneError(f"{where} is missing the required key(s) {missing}; "
                         f"required keys: {required}")
    try:
        return cls(**kwargs)
    except StereoforgeError as exc:  # the same class, told where in the scene
        raise type(exc)(f"{where}: {exc}") from None


def scene_from_dict(data: dict[str, Any]) -> SceneSpec:
    """Build a :class:`SceneSpec` from the nested dict written by :func:`scene_to_dict`.

    Raises
    ------
    SceneError
        On an unknown key (naming it, where it is and the valid keys), a missing required key or
        an unsupported format version (a ``ValueError``).
    stereoforge.errors.ParameterError
        On an unknown kind or an out-of-range value (a ``ValueError``).
    stereoforge.errors.ParameterTypeError
        On a value of the wrong type (a ``TypeError``).

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
            raise SceneError(f"unsupported scene format version {version!r}; "
                             f"this stereoforge reads version {_FORMAT_VERSION}")
    top = _take(data, SceneSpec, "scene")
    raw_objects = check_type(top.get("objects", []), "scene.objects", (list, tuple),
                             expected="an array of tables")
    objects = []
    for i, raw in enumerate(raw_objects):
        where = f"objects[{i}]"
        kw = _take(raw, ObjectSpec, where)
        kw["pose"] = _build(Pose, _take(kw.get("pose", {}), Pose, f"{where}.pose"), f"{where}.pose")
        kw["texture"] = _build(TextureSpec, _take(kw.get("texture", {}), TextureSpec,
                                                  f"{where}.texture"), f"{where}.texture")
        if "material" in kw:
            kw["material"] = _build(MaterialSpec, _take(kw["material"], MaterialSpec,
                                                        f"{where}.material"), f"{where}.material")
        objects.append(_build(ObjectSpec, kw, where))
    top["objects"] = tuple(objects)
    if "light" in top:
        top["light"] = _build(LightSpec, _take(top["light"], LightSpec, "scene.light"),
                              "scene.light")
    if "lamps" in top:
        raw_lamps = check_type(top["lamps"], "scene.lamps", (list, tuple),
                               expected="an array of tables")
        top["lamps"] = tuple(_build(LampSpec, _take(raw, LampSpec, f"lamps[{i}]"), f"lamps[{i}]")
                             for i, raw in enumerate(raw_lamps))
    if "sky" in top:
        top["sky"] = _build(SkySpec, _take(top["sky"], SkySpec, "scene.sky"), "scene.sky")
    return _build(SceneSpec, top, "scene")


# --------------------------------------------------------------------------- text formats
def dumps_json(spec: SceneSpec) -> str:
    """JSON text of a scene (floats in shortest round-trip form)."""
    return json.dumps(scene_to_dict(spec), indent=2) + "\n"


def _parse_text(loads: Any, text: Any, kind: str, where: str) -> Any:
    """``loads(text)`` with every failure of the parser as a :class:`SceneError` at ``where``."""
    check_type(text, "text", str, expected=f"the {kind} text of a scene (str)")
    try:
        return loads(text)
    except RecursionError:
        raise SceneError(f"{where}: {kind} nested too deeply for this parser; a scene is a "
                         "few levels deep (scene, objects, pose)") from None
    except ValueError as exc:  # JSONDecodeError, TOMLDecodeError, an int of > 4300 digits
        raise SceneError(f"{where}: invalid {kind}: {exc}") from None


def loads_json(text: str, *, source: str = "scene") -> SceneSpec:
    """Scene from JSON text written by :func:`dumps_json`.

    Raises
    ------
    SceneError
        On invalid JSON (``source`` names it) or an invalid scene.
    """
    return scene_from_dict(_parse_text(json.loads, text, "JSON", source))


def dumps_toml(spec: SceneSpec) -> str:
    """TOML text of a scene (floats in shortest round-trip form)."""
    return tomli_w.dumps(scene_to_dict(spec))


def loads_toml(text: str, *, source: str = "scene") -> SceneSpec:
    """Scene from TOML text written by :func:`dumps_toml`.

    Raises
    ------
    SceneError
        On invalid TOML (``source`` names it) or an invalid scene.
    """
    return scene_from_dict(_parse_text(tomllib.loads, text, "TOML", source))


_FORMATS = {".json": (dumps_json, loads_json), ".toml": (dumps_toml, loads_toml)}


def _format(path: Path) -> tuple[Any, Any]:
    try:
        return _FORMATS[path.suffix.lower()]
    except KeyError:
        raise fail(f"scene file {str(path)!r}", f"a suffix in {sorted(_FORMATS)}",
                   repr(path.suffix), error=SceneError) from None


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
    text = check_text(path.read_bytes(), str(path), fix="save the scene file as UTF-8",
                      error=SceneError)
    try:
        return loads(text, source=str(path))
    except StereoforgeError as exc:  # the same class, told which file
        if str(exc).startswith(str(path)):
            raise
        raise type(exc)(f"{path}: {exc}") from None
