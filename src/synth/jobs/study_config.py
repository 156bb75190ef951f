"""Configuration of the texture-versus-window study (:mod:`synth.jobs.study`): TOML in, validated
:class:`StudyConfig` out, errors with the file and line (:class:`StudyConfigError`)."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from synth._toml import line_of
from synth.rig import StereoRig

__all__ = ["StudyConfig", "StudyConfigError", "load_study_config", "loads_study_config",
           "list_studies"]

_METHODS = ("ct", "sct", "cthw", "awct", "awsct", "bm", "sgbm")
_SCHEMA: dict[str, dict[str, str]] = {
    "": {"name": "str", "description": "str", "seeds": "ints", "max_disparity": "int",
         "delta": "float", "rig": "table", "scene": "table", "match": "table"},
    "rig": {"width": "int", "height": "int", "baseline": "float", "fx": "float"},
    "scene": {"kinds": "strs", "texture": "str", "frequencies_px": "floats",
              "edge_densities": "floats", "contrasts": "floats", "noise_sigma": "float"},
    "match": {"methods": "strs", "windows": "ints"},
}


class StudyConfigError(ValueError):
    """A study configuration is invalid; the message gives ``file:line`` and the valid keys."""


@dataclass(frozen=True)
class StudyConfig:
    """A parsed study configuration (see ``docs/study.md`` for every key).

    Examples
    --------
    >>> cfg = loads_study_config('seeds = [0]\\n[scene]\\nfrequencies_px = [0.1]\\n')
    >>> cfg.rig.width, cfg.kinds, cfg.levels
    (320, ('slanted_plane', 'boxes'), (0.1,))
    """

    name: str
    description: str
    rig: StereoRig
    kinds: tuple[str, ...]
    texture: str
    axis: str  # "frequency" or "edge_density"
    levels: tuple[float, ...]
    contrasts: tuple[float, ...]
    noise_sigma: float
    seeds: tuple[int, ...]
    methods: tuple[str, ...]
    windows: tuple[int, ...]
    max_disparity: int
    delta: float
    source: str = "<string>"
    text: str = ""

    def cells(self) -> list[tuple[str, float, float, int]]:
        """``(kind, level, contrast, seed)`` of every cell, in results order."""
        return [(k, lv, c, s) for k in self.kinds for lv in self.levels for c in self.contrasts
                for s in self.seeds]


# --------------------------------------------------------------------------- config parsing
def _coerce(kind: str, value: Any) -> Any:
    def num(v: Any, integer: bool) -> Any:
        ok = isinstance(v, int) if integer else isinstance(v, (int, float))
        if isinstance(v, bool) or not ok:
            raise TypeError("an integer" if integer else "a number")
        return int(v) if integer else float(v)

    if kind in ("int", "float"):
        return num(value, kind == "int")
    if kind == "str":
        if not isinstance(value, str):
            raise TypeError("a string")
        return value
    if not isinstance(value, list) or not value:
        raise TypeError("a non-empty array")
    if kind == "strs":
        if not all(isinstance(v, str) for v in value):
            raise TypeError("an array of strings")
        return tuple(value)
    return tuple(num(v, kind == "ints") for v in value)


def loads_study_config(text: str, *, source: str = "<string>") -> StudyConfig:
    """Parse a study configuration from TOML text (see :func:`load_study_config`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyConfigError(f"{source}: invalid TOML: {exc}") from None

    def fail(section: str, key: str, message: str) -> StudyConfigError:
        line = line_of(text, section, key)
        where = f"{source}:{line}" if line else source
        return StudyConfigError(f"{where}: {section + '.' if section else ''}{key}: {message}")

    values: dict[str, dict[str, Any]] = {s: {} for s in _SCHEMA}
    for section, schema in _SCHEMA.items():
        table = data if not section else data.get(section, {})
        if not isinstance(table, dict):
            raise fail("", section, "expected a table")
        for key, value in table.items():
            if key not in schema:
                raise fail(section, key, f"unknown key; valid keys of "
                           f"{'[' + section + ']' if section else 'the top level'}: "
                           f"{', '.join(schema)}")
            if schema[key] == "table":
                continue
            try:
                values[section][key] = _coerce(schema[key], value)
            except TypeError as exc:
                raise fail(section, key, f"expected {exc}, got {value!r}") from None
    top, rig, scene, mt = (values[s] for s in ("", "rig", "scene", "match"))

    def check(ok: bool, section: str, key: str, message: str) -> None:
        if not ok:
            raise fail(section, key, message)

    from scenes import PRESETS
    from scenes.spec import TEXTURE_KINDS

    kinds = scene.get("kinds", ("slanted_plane", "boxes"))
    for k in kinds:
        check(k in PRESETS, "scene", "kinds", f"unknown scene {k!r}; valid: {', '.join(PRESETS)}")
    texture = scene.get("texture", "noise")
    check(texture in TEXTURE_KINDS and texture != "constant", "scene", "texture",
          f"expected one of noise, checker, stripes, got {texture!r}")
    has_f, has_e = "frequencies_px" in scene, "edge_densities" in scene
    check(has_f != has_e, "scene", "frequencies_px" if has_f else "edge_densities",
          "give exactly one of frequencies_px (cycles per pixel) and edge_densities")
    axis = "frequency" if has_f else "edge_density"
    levels = scene["frequencies_px"] if has_f else scene["edge_densities"]
    hi = 0.5 if has_f else 1.0
    for lv in levels:
        check(0 < lv < hi, "scene", "frequencies_px" if has_f else "edge_densities",
              f"values must be in (0, {hi}), got {lv}")
    contrasts = scene.get("contrasts", (0.8,))
    check(all(0 < c <= 1 for c in contrasts), "scene", "contrasts", "values must be in (0, 1]")
    noise = scene.get("noise_sigma", 2.0)
    check(0 <= noise <= 64, "scene", "noise_sigma", f"must be in [0, 64] grey levels, got {noise}")
    methods = mt.get("methods", ("ct", "sct", "cthw", "awct", "awsct", "sgbm"))
    for m in methods:
        check(m in _METHODS, "match", "methods", f"unknown method {m!r}; valid: {', '.join(_METHODS)}")
    windows = mt.get("windows", (5, 9, 13, 17, 21))
    check(all(3 <= w <= 255 and w % 2 for w in windows), "match", "windows",
          "values must be odd integers in [3, 255]")
    check("bm" not in methods or min(windows) >= 5, "match", "windows", "bm needs windows >= 5")
    seeds = top.get("seeds", (0, 1, 2))
    check(all(0 <= s < 2**63 for s in seeds), "", "seeds", "seeds must be in [0, 2**63)")
    for section, key, group in (("scene", "kinds", kinds), ("scene", "contrasts", contrasts),
                                ("", "seeds", seeds), ("match", "methods", methods),
                                ("match", "windows", windows),
                                ("scene", "frequencies_px" if has_f else "edge_densities", levels)):
        check(len(set(group)) == len(group), section, key, "values must be distinct")
    try:
        the_rig = StereoRig.default(rig.get("width", 320), rig.get("height", 240),
                                    fx=rig.get("fx"), baseline=rig.get("baseline", 0.2))
    except (TypeError, ValueError) as exc:
        raise fail("", "rig", str(exc)) from None
    max_disp = top.get("max_disparity", 48)
    check(1 <= max_disp < the_rig.width, "", "max_disparity",
          f"must be in [1, width = {the_rig.width}), got {max_disp}")
    check(max(windows) <= min(the_rig.width, the_rig.height), "match", "windows",
          "windows must fit in the image")
    delta = top.get("delta", 3.0)
    check(delta > 0, "", "delta", f"must be > 0, got {delta}")
    return StudyConfig(
        name=top.get("name", Path(source).stem), description=top.get("description", ""),
        rig=the_rig, kinds=kinds, texture=texture, axis=axis, levels=levels,
        contrasts=contrasts, noise_sigma=noise, seeds=seeds, methods=methods, windows=windows,
        max_disparity=max_disp, delta=delta, source=source, text=text)


def list_studies() -> list[str]:
    """Names of the shipped study configurations (``src/synth/dataset/configs/study-*.toml``).

    Examples
    --------
    >>> "study-texture-window" in list_studies()
    True
    """
    folder = resources.files("synth.dataset") / "configs"
    return sorted(p.name[:-5] for p in folder.iterdir()
                  if p.name.startswith("study-") and p.name.endswith(".toml"))


def load_study_config(config: str | Path | StudyConfig) -> StudyConfig:
    """A study configuration from a ``.toml`` path or a shipped name.

    Parameters
    ----------
    config : str, Path or StudyConfig
        A TOML file, a shipped name (``"study-texture-window"`` or ``"texture-window"``) or an
        already parsed configuration (returned as is).

    Examples
    --------
    >>> load_study_config("texture-window").name
    'texture-window'
    """
    if isinstance(config, StudyConfig):
        return config
    if not isinstance(config, (str, Path)):
        raise TypeError(f"config must be a path or a study name, got {type(config).__name__}")
    name = str(config)
    shipped = list_studies()
    for candidate in (name, f"study-{name}"):
        if Path(name).suffix != ".toml" and candidate in shipped:
            res = resources.files("synth.dataset") / "configs" / f"{candidate}.toml"
            return loads_study_config(res.read_text(encoding="utf-8"), source=f"{candidate}.toml")
    path = Path(config)
    if not path.is_file():
        raise FileNotFoundError(f"study config {path} does not exist; pass a .toml file or one "
                                f"of the shipped studies: {', '.join(shipped)}")
    return loads_study_config(path.read_text(encoding="utf-8"), source=str(path))
