"""Configuration of the texture-versus-window study (:mod:`synth.jobs.study.run`): TOML in,
validated :class:`StudyConfig` out, errors with the file and line (:class:`StudyConfigError`)."""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

from matcher import METHODS
from scenes import PRESETS
from scenes.spec import TEXTURE_KINDS
from stereoforge.errors import ConfigError, StereoforgeError
from stereoforge.schema import Key
from stereoforge.validation import check_input_file
from synth._util.toml_lines import TomlSource, parse_toml, read_toml_text
from synth.camera.rig import StereoRig

__all__ = ["SCHEMA", "StudyConfig", "StudyConfigError", "load_study_config",
           "loads_study_config", "list_studies"]

_TEXTURES = tuple(k for k in TEXTURE_KINDS if k not in ("constant", "image"))  # procedural, textured
_MAX_SEED = 2**63
_TABLES = ("rig", "scene", "match")

#: Every table, key and its schema (``""`` is the top level); see docs/study.md.
SCHEMA: Mapping[str, Mapping[str, Key]] = MappingProxyType({
    "": {
        "name": Key("str", None, doc="study name (default: the file's stem)"),
        "description": Key("str", "", doc="free text"),
        "seeds": Key("int", (0, 1, 2), lo=0, hi=_MAX_SEED, hi_open=True, array=True,
                     distinct=True, doc="scene seeds of every cell"),
        "max_disparity": Key("int", 48, lo=1, doc="disparity search range, below the width"),
        "delta": Key("float", 3.0, lo=0.0, lo_open=True, doc="bad-pixel threshold, pixels"),
    },
    "rig": {
        "width": Key("int", 320, lo=0, lo_open=True, doc="image width, pixels"),
        "height": Key("int", 240, lo=0, lo_open=True, doc="image height, pixels"),
        "baseline": Key("float", 0.2, lo=0.0, lo_open=True, doc="baseline, metres"),
        "fx": Key("float", None, lo=0.0, lo_open=True, doc="focal length, pixels"),
    },
    "scene": {
        "kinds": Key("str", ("slanted_plane", "boxes"), choices=tuple(PRESETS), array=True,
                     distinct=True, doc="scene presets"),
        "texture": Key("str", "noise", choices=_TEXTURES, doc="texture kind"),
        "frequencies_px": Key("float", None, lo=0, hi=0.5, lo_open=True, hi_open=True,
                              array=True, distinct=True, doc="texture frequencies, cycles/px"),
        "edge_densities": Key("float", None, lo=0, hi=1, lo_open=True, hi_open=True,
                              array=True, distinct=True, doc="target Canny edge densities"),
        "sweep_key": Key("str", None, doc="a dataset-config key 'section.key' swept instead of "
                                          "the texture (e.g. photometric.gain)"),
        "sweep_values": Key("float", None, array=True, distinct=True,
                            doc="values of sweep_key, one level each"),
        "contrasts": Key("float", (0.8,), lo=0, hi=1, lo_open=True, array=True,
                         distinct=True, doc="texture contrasts"),
        "noise_sigma": Key("float", 2.0, lo=0, hi=64, doc="sensor noise, grey levels"),
    },
    "match": {
        "methods": Key("str", ("ct", "sct", "cthw", "awct", "awsct", "sgbm"), choices=METHODS,
                       array=True, distinct=True, doc="matchers compared"),
        "windows": Key("int", (5, 9, 13, 17, 21), lo=3, hi=255, odd=True, array=True,
                       distinct=True, doc="window sides"),
    },
})


class StudyConfigError(ConfigError):
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
    axis: str  # "frequency", "edge_density" or a swept dataset-config key "section.key"
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
    matchers: tuple[str, ...] = ()  # MATCHER strings run once per cell (window column empty)

    def cells(self) -> list[tuple[str, float, float, int]]:
        """``(kind, level, contrast, seed)`` of every cell, in results order."""
        return [(k, lv, c, s) for k in self.kinds for lv in self.levels for c in self.contrasts
                for s in self.seeds]


# --------------------------------------------------------------------------- config parsing
def loads_study_config(text: str, *, source: str = "<string>") -> StudyConfig:
    """Parse a study configuration from TOML text (see :func:`load_study_config`).

    Raises
    ------
    StudyConfigError
        ``source:line: table.key: expected ..., got ...; fix`` (see :data:`SCHEMA`).

    Examples
    --------
    >>> loads_study_config("[match]\\nwindows = [5, 8]\\n", source="s.toml")
    Traceback (most recent call last):
    ...
    synth.jobs.study.config.StudyConfigError: s.toml:2: match.windows[1]: expected an odd integer in [3, 255], got 8
    """
    data = parse_toml(text, source, StudyConfigError)
    toml = TomlSource(text, source, StudyConfigError)
    top = toml.table(data, (), SCHEMA[""], skip=_TABLES)
    tables = {name: toml.table(data.get(name, {}), (name,), SCHEMA[name]) for name in _TABLES}
    scene = tables["scene"]

    def get(table: str, key: str) -> Any:
        values = top if not table else tables[table]
        return values[key] if key in values else SCHEMA[table][key].default

    has_f, has_e = "frequencies_px" in scene, "edge_densities" in scene
    has_s = "sweep_values" in scene
    axis_key = "frequencies_px" if has_f else "edge_densities" if has_e else "sweep_values"
    if has_f + has_e + has_s != 1:
        raise toml.fail(("scene", axis_key), "exactly one of frequencies_px (cycles per pixel), "
                        "edge_densities and sweep_values",
                        "neither" if not has_f + has_e + has_s else "more than one")
    sweep_key = scene.get("sweep_key")
    if has_s != (sweep_key is not None):
        raise toml.fail(("scene", "sweep_key" if has_s else "sweep_values"),
                        "sweep_key and sweep_values together", "only one of them")
    methods, windows = get("match", "methods"), get("match", "windows")
    if "bm" in methods and min(windows) < 5:
        raise toml.fail(("match", "windows"), "windows >= 5 when methods include 'bm'",
                        repr(list(windows)), fix="drop the 3 or the 'bm'")
    try:
        the_rig = StereoRig.default(get("rig", "width"), get("rig", "height"),
                                    fx=get("rig", "fx"), baseline=get("rig", "baseline"))
    except StereoforgeError as exc:
        raise StudyConfigError(f"{toml.where('rig')}: rig: {exc}") from None
    max_disp = get("", "max_disparity")
    if not max_disp < the_rig.width:
        raise toml.fail(("max_disparity",), f"an integer in [1, {the_rig.width})",
                        repr(max_disp), fix=f"keep it below rig.width = {the_rig.width}")
    side = min(the_rig.width, the_rig.height)
    if max(windows) > side:
        raise toml.fail(("match", "windows"), f"windows that fit in the image, <= {side}",
                        repr(list(windows)), fix="use smaller windows or a larger rig")
    levels = scene[axis_key]
    if has_s:
        levels = _sweep_levels(toml, sweep_key, levels)
    return StudyConfig(
        name=top.get("name", Path(source).stem), description=get("", "description"),
        rig=the_rig, kinds=get("scene", "kinds"), texture=get("scene", "texture"),
        axis="frequency" if has_f else "edge_density" if has_e else sweep_key, levels=levels,
        contrasts=get("scene", "contrasts"), noise_sigma=get("scene", "noise_sigma"),
        seeds=get("", "seeds"), methods=methods, windows=windows, max_disparity=max_disp,
        delta=get("", "delta"), source=source, text=text)


def _sweep_levels(toml: TomlSource, key: str, values: tuple) -> tuple:
    """``values`` checked as values of the dataset-config key ``key`` (ints where it takes ints)."""
    from synth.dataset.config.parse import SCHEMA as DATASET_SCHEMA
    from synth.dataset.config.parse import config_from_dict

    section, _, name = key.partition(".")
    keys = [f"{s}.{k}" for s in ("rig", "scene", "photometric") for k in DATASET_SCHEMA[s]
            if (s, k) not in _NOT_SWEPT]
    if key not in keys:
        raise toml.fail(("scene", "sweep_key"), f"a dataset-config key: {', '.join(keys)}",
                        repr(key))
    spec = DATASET_SCHEMA[section][name]
    out = []
    for v in values:
        v = int(v) if spec.kind == "int" and float(v).is_integer() else v
        try:
            config_from_dict({section: {name: v}})
        except StereoforgeError as exc:
            raise toml.fail(("scene", "sweep_values"), f"values of {key}", repr(v),
                            fix=str(exc).split(": ", 1)[-1]) from None
        out.append(v)
    return tuple(out)


#: Dataset-config keys a study sets itself (the rig's size and the scene) and cannot sweep.
_NOT_SWEPT = {("rig", "width"), ("rig", "height"), ("rig", "fx"), ("scene", "base"),
              ("scene", "texture"), ("scene", "contrast")}


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
    path = check_input_file(config, "study config", suffixes=(".toml",),
                            fix=f"pass a .toml file or one of the shipped studies: "
                                f"{', '.join(shipped)}")
    return loads_study_config(read_toml_text(path, StudyConfigError), source=str(path))
