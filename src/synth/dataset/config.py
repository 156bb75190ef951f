"""Dataset configurations: a TOML file of rig, scene distributions and photometric models.

A configuration is data (:class:`DatasetConfig`): fixed rig values plus, for every scene and
photometric parameter, a distribution (:class:`Dist`) that each sample draws from with its own
random generator. Every error names the file, the line of the offending key and the allowed
values (:exc:`ConfigError`). ``docs/datasets.md`` is the reference of every key.

Distributions are written as a plain value (fixed), ``{uniform = [a, b]}``,
``{loguniform = [a, b]}`` (``a > 0``) or ``{choice = [v1, v2, ...]}``. An integer key drawn from
``uniform``/``loguniform`` gives integers in ``[a, b]`` (both ends included).
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from scenes import PRESETS
from synth._toml import line_of
from synth.rig import StereoRig

__all__ = [
    "ConfigError",
    "Dist",
    "DatasetConfig",
    "SCHEMA",
    "EXAMPLES",
    "load_config",
    "loads_config",
    "config_from_dict",
    "list_examples",
]

_MAX_SEED = 2**63
DIST_KINDS = ("uniform", "loguniform", "choice")


class ConfigError(ValueError):
    """A dataset configuration is invalid; the message gives ``file:line`` and the fix."""


@dataclass(frozen=True)
class _Key:
    """Schema of one key: type, bounds or choices, default, whether it may be a distribution."""

    type: str  # "float" | "int" | "str" | "bool"
    default: Any
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    choices: tuple[Any, ...] | None = None
    dist: bool = True
    optional: bool = False  # default None means "not set"
    doc: str = ""

    def allowed(self) -> str:
        """Human description of the allowed values."""
        if self.choices is not None:
            text = "one of " + ", ".join(repr(c) for c in self.choices)
        elif self.type == "bool":
            text = "true or false"
        else:
            lo = "-inf" if self.lo is None else repr(self.lo)
            hi = "inf" if self.hi is None else repr(self.hi)
            text = f"{'an integer' if self.type == 'int' else 'a number'} in {'(' if self.lo_open else '['}{lo}, {hi}]"
        if self.dist:
            text += " (or {uniform=[a,b]}, {loguniform=[a,b]}, {choice=[...]})" if self.type in (
                "float", "int") else " (or {choice=[...]})"
        return text


_SCENE_TEXTURES = ("preset", "noise", "checker", "stripes", "constant")
_OCCLUDER_KINDS = ("box", "sphere", "cylinder")

#: Every section, key and its schema (``""`` is the top level).
SCHEMA: Mapping[str, Mapping[str, _Key]] = MappingProxyType({
    "": {
        "name": _Key("str", "dataset", dist=False, doc="dataset name"),
        "seed": _Key("int", 0, lo=0, hi=_MAX_SEED - 1, dist=False, doc="dataset seed"),
        "count": _Key("int", 10, lo=1, hi=999_999, dist=False, doc="number of samples"),
        "preview": _Key("bool", False, dist=False, doc="also write preview.png per sample"),
    },
    "rig": {
        "width": _Key("int", 640, lo=8, hi=8192, dist=False, doc="image width, pixels"),
        "height": _Key("int", 480, lo=8, hi=8192, dist=False, doc="image height, pixels"),
        "fx": _Key("float", None, lo=0.0, lo_open=True, dist=False, optional=True,
                   doc="focal length in pixels (fy = fx); default 600 * width / 640"),
        "baseline": _Key("float", 0.1, lo=0.0, lo_open=True, hi=100.0, dist=False,
                         doc="baseline, metres"),
        "near": _Key("float", 0.1, lo=0.0, lo_open=True, dist=False, doc="near plane, metres"),
        "far": _Key("float", 100.0, lo=0.0, lo_open=True, dist=False, doc="far plane, metres"),
    },
    "scene": {
        "base": _Key("str", "fronto_plane", choices=tuple(PRESETS), doc="base preset"),
        "texture": _Key("str", "preset", choices=_SCENE_TEXTURES,
                        doc="texture kind of every object ('preset' keeps the preset's)"),
        "frequency_px": _Key("float", None, lo=0.0, lo_open=True, hi=0.5, optional=True,
                             doc="texture frequency, cycles per pixel at each object's depth"),
        "contrast": _Key("float", None, lo=0.0, hi=1.0, optional=True, doc="texture contrast"),
        "edge_density": _Key("float", None, lo=0.005, hi=0.45, optional=True,
                             doc="target Canny edge density of the left image (closed loop)"),
        "occluders": _Key("int", 0, lo=0, hi=64, doc="number of occluding objects added"),
        "occluder_size": _Key("float", 0.15, lo=0.0, lo_open=True, hi=1.0,
                              doc="occluder size, fraction of the image width"),
        "occluder_depth": _Key("float", 1.5, lo=0.0, lo_open=True,
                               doc="occluder centre depth, metres"),
        "occluder_kind": _Key("str", "box", choices=_OCCLUDER_KINDS, doc="occluder shape"),
    },
    "photometric": {
        "noise_sigma": _Key("float", 0.0, lo=0.0, hi=64.0,
                            doc="Gaussian noise standard deviation, grey levels (0..255)"),
        "gain": _Key("float", 1.0, lo=0.0, lo_open=True, hi=4.0,
                     doc="gain of the right image relative to the left"),
        "bias": _Key("float", 0.0, lo=-128.0, hi=128.0,
                     doc="bias of the right image relative to the left, grey levels"),
        "gamma": _Key("float", 1.0, lo=0.1, hi=10.0, doc="gamma applied to both images"),
        "blur_sigma": _Key("float", 0.0, lo=0.0, hi=16.0,
                           doc="Gaussian blur standard deviation, pixels, both images"),
        "jpeg_quality": _Key("int", 0, lo=0, hi=100, doc="JPEG round trip quality, 0 = off"),
    },
})

#: Shipped example configurations (``src/synth/dataset/configs/<name>.toml``).
EXAMPLES = ("planes", "texture-sweep", "flying")


# --------------------------------------------------------------------------- distributions
@dataclass(frozen=True)
class Dist:
    """A distribution of one parameter.

    Parameters
    ----------
    kind : {"fixed", "uniform", "loguniform", "choice"}
    args : tuple
        ``(value,)`` for fixed, ``(a, b)`` for uniform/loguniform, the values for choice.
    integer : bool
        Draws of uniform/loguniform are integers in ``[a, b]``.

    Examples
    --------
    >>> d = Dist("uniform", (1.0, 2.0))
    >>> 1.0 <= d.sample(np.random.default_rng(0)) <= 2.0
    True
    >>> Dist("choice", ("a", "b")).to_toml()
    {'choice': ['a', 'b']}
    """

    kind: str
    args: tuple[Any, ...]
    integer: bool = False

    def sample(self, rng: np.random.Generator) -> Any:
        """One draw (plain Python value). Fixed values consume no randomness."""
        if self.kind == "fixed":
            return self.args[0]
        if self.kind == "choice":
            value = self.args[int(rng.integers(len(self.args)))]
            return value
        a, b = self.args
        if self.kind == "uniform":
            if self.integer:
                return int(rng.integers(int(a), int(b) + 1))
            return float(rng.uniform(a, b))
        x = math.exp(rng.uniform(math.log(a), math.log(b + 1 if self.integer else b)))
        return min(int(math.floor(x)), int(b)) if self.integer else float(x)

    def to_toml(self) -> Any:
        """The TOML/JSON value this distribution was written as."""
        return self.args[0] if self.kind == "fixed" else {self.kind: list(self.args)}


# --------------------------------------------------------------------------- the config
@dataclass(frozen=True)
class DatasetConfig:
    """A parsed, validated dataset configuration.

    Attributes
    ----------
    name : str
    seed : int
        Dataset seed; sample ``i`` draws from ``SeedSequence(seed, spawn_key=(i,))``.
    count : int
        Number of samples (``run_dataset(count=...)`` overrides it).
    preview : bool
    rig : StereoRig
    scene, photometric : Mapping[str, Dist]
        Every key of the section (defaults filled in as fixed values; optional keys left unset
        are absent).
    source : str
        File the configuration came from (``"<string>"`` for text).

    Examples
    --------
    >>> cfg = loads_config('seed = 3\\n[rig]\\nwidth = 32\\nheight = 24\\n')
    >>> cfg.rig.width, cfg.scene["base"].to_toml(), len(cfg.hash())
    (32, 'fronto_plane', 64)
    """

    name: str
    seed: int
    count: int
    preview: bool
    rig: StereoRig
    scene: Mapping[str, Dist]
    photometric: Mapping[str, Dist]
    source: str = field(default="<string>", compare=False)

    def to_dict(self, *, with_count: bool = True) -> dict[str, Any]:
        """Canonical plain dict (the TOML structure, defaults filled in)."""
        rig = {k: v for k, v in self.rig.to_dict().items() if k in SCHEMA["rig"]}
        out: dict[str, Any] = {"name": self.name, "seed": self.seed, "preview": self.preview,
                               "rig": rig,
                               "scene": {k: d.to_toml() for k, d in sorted(self.scene.items())},
                               "photometric": {k: d.to_toml()
                                               for k, d in sorted(self.photometric.items())}}
        if with_count:
            out["count"] = self.count
        return out

    def hash(self) -> str:
        """SHA-256 of the canonical configuration without ``count`` (which may grow)."""
        text = json.dumps(self.to_dict(with_count=False), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


class _Parser:
    def __init__(self, text: str, source: str) -> None:
        self.text, self.source = text, source

    def fail(self, section: str, key: str | None, message: str) -> ConfigError:
        line = line_of(self.text, section, key) if self.text else None
        where = f"{self.source}:{line}" if line else self.source
        table = f"[{section}] " if section else ""
        return ConfigError(f"{where}: {table}{message}")

    def scalar(self, section: str, key: str, spec: _Key, value: Any, what: str = "") -> Any:
        label = f"{key}{what}"
        if isinstance(value, dict):
            raise self.fail(section, key, f"{label} takes a fixed value, not a distribution or "
                            f"table; allowed: {spec.allowed()}")
        if spec.type == "bool":
            if not isinstance(value, bool):
                raise self.fail(section, key, f"{label} must be true or false, got {value!r}")
            return value
        if spec.type == "str":
            if not isinstance(value, str) or (spec.choices and value not in spec.choices):
                raise self.fail(section, key, f"{label} = {value!r} is not allowed; "
                                f"allowed: {spec.allowed()}")
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(section, key, f"{label} must be a number, got {value!r}; "
                            f"allowed: {spec.allowed()}")
        if spec.type == "int":
            if isinstance(value, float):
                if not value.is_integer():
                    raise self.fail(section, key, f"{label} must be an integer, got {value!r}; "
                                    f"allowed: {spec.allowed()}")
                value = int(value)
        else:
            value = float(value)
        bad = not math.isfinite(value)
        if spec.lo is not None:
            bad |= value <= spec.lo if spec.lo_open else value < spec.lo
        if spec.hi is not None:
            bad |= value > spec.hi
        if bad:
            raise self.fail(section, key, f"{label} = {value!r} is out of range; "
                            f"allowed: {spec.allowed()}")
        return value

    def dist(self, section: str, key: str, spec: _Key, value: Any) -> Dist:
        if not isinstance(value, dict):
            if isinstance(value, list):
                raise self.fail(section, key, f"{key} is a list; write a distribution as "
                                f"{{choice = {value!r}}} or {{uniform = [a, b]}}")
            return Dist("fixed", (self.scalar(section, key, spec, value),))
        if not spec.dist:
            raise self.fail(section, key, f"{key} takes a fixed value, not a distribution; "
                            f"allowed: {spec.allowed()}")
        if len(value) != 1 or next(iter(value)) not in DIST_KINDS:
            raise self.fail(section, key, f"{key} = {value!r} is not a distribution; allowed: "
                            "exactly one of {uniform=[a,b]}, {loguniform=[a,b]}, "
                            "{choice=[...]}")
        kind, args = next(iter(value.items()))
        if not isinstance(args, list) or not args:
            raise self.fail(section, key, f"{key}: {kind} needs a non-empty list, got {args!r}")
        if kind == "choice":
            return Dist("choice", tuple(self.scalar(section, key, spec, v, f" choice[{i}]")
                                        for i, v in enumerate(args)))
        if spec.type not in ("float", "int"):
            raise self.fail(section, key, f"{key} is a {spec.type}; only {{choice=[...]}} "
                            f"applies; allowed: {spec.allowed()}")
        if len(args) != 2:
            raise self.fail(section, key, f"{key}: {kind} needs [a, b], got {args!r}")
        a, b = (self.scalar(section, key, spec, v, f" {kind} bound") for v in args)
        if a > b:
            raise self.fail(section, key, f"{key}: {kind} needs a <= b, got [{a}, {b}]")
        if kind == "loguniform" and a <= 0:
            raise self.fail(section, key, f"{key}: loguniform needs a > 0, got [{a}, {b}]")
        return Dist(kind, (a, b), integer=spec.type == "int")

    def section(self, data: Mapping[str, Any], section: str) -> dict[str, Any]:
        schema = SCHEMA[section]
        for key in data:
            if key not in schema:
                raise self.fail(section, key, f"unknown key {key!r}; allowed keys: "
                                f"{', '.join(schema)}")
        return {k: data[k] for k in schema if k in data}

    def parse(self, data: Mapping[str, Any]) -> DatasetConfig:
        if not isinstance(data, Mapping):
            raise ConfigError(f"{self.source}: a configuration is a table, got "
                              f"{type(data).__name__}")
        tables = [s for s in SCHEMA if s]
        for key, value in data.items():
            if key in tables:
                if not isinstance(value, Mapping):
                    raise self.fail("", key, f"{key} must be a table [{key}]")
            elif key not in SCHEMA[""]:
                raise self.fail("", key, f"unknown key {key!r}; allowed keys: "
                                f"{', '.join([*SCHEMA[''], *tables])} (tables: "
                                f"{', '.join(f'[{t}]' for t in tables)})")
        top = {k: self.scalar("", k, SCHEMA[""][k], v) for k, v in data.items()
               if k in SCHEMA[""]}
        name = top.get("name", Path(self.source).stem if self.source != "<string>" else "dataset")
        rig_kw = {k: self.scalar("rig", k, SCHEMA["rig"][k], v)
                  for k, v in self.section(data.get("rig", {}), "rig").items()}
        rig_kw = {k: rig_kw.get(k, SCHEMA["rig"][k].default) for k in SCHEMA["rig"]}
        fx = rig_kw["fx"] if rig_kw["fx"] is not None else 600.0 * rig_kw["width"] / 640.0
        if not rig_kw["near"] < rig_kw["far"]:
            raise self.fail("rig", "far", f"need near < far, got near={rig_kw['near']}, "
                            f"far={rig_kw['far']}")
        rig = StereoRig(width=rig_kw["width"], height=rig_kw["height"], fx=fx, fy=fx,
                        cx=(rig_kw["width"] - 1) / 2.0, cy=(rig_kw["height"] - 1) / 2.0,
                        baseline=rig_kw["baseline"], near=rig_kw["near"], far=rig_kw["far"])
        sections = {}
        for sec in ("scene", "photometric"):
            raw = self.section(data.get(sec, {}), sec)
            out = {}
            for key, spec in SCHEMA[sec].items():
                if key in raw:
                    out[key] = self.dist(sec, key, spec, raw[key])
                elif not spec.optional:
                    out[key] = Dist("fixed", (spec.default,))
            sections[sec] = out
        scene = sections["scene"]
        if "edge_density" in scene and "frequency_px" in scene:
            raise self.fail("scene", "edge_density", "edge_density and frequency_px exclude "
                            "each other: edge_density chooses the frequency; remove one")
        if "edge_density" in scene and scene["texture"].to_toml() == "constant":
            raise self.fail("scene", "edge_density", "edge_density needs a textured surface; "
                            "texture = 'constant' has none")
        return DatasetConfig(
            name=name, seed=top.get("seed", 0), count=top.get("count", 10),
            preview=top.get("preview", False), rig=rig,
            scene=MappingProxyType(scene), photometric=MappingProxyType(sections["photometric"]),
            source=self.source,
        )


def loads_config(text: str, *, source: str = "<string>") -> DatasetConfig:
    """Parse a configuration from TOML text.

    Raises
    ------
    ConfigError
        ``source:line: [section] message; allowed: ...`` for a syntax error, an unknown key, a
        value of the wrong type or out of range.

    Examples
    --------
    >>> loads_config("[scene]\\nocluders = 2\\n", source="my.toml")
    Traceback (most recent call last):
    ...
    synth.dataset.config.ConfigError: my.toml:2: [scene] unknown key 'ocluders'; allowed keys: base, texture, frequency_px, contrast, edge_density, occluders, occluder_size, occluder_depth, occluder_kind
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: invalid TOML: {exc}") from None
    return _Parser(text, source).parse(data)


def config_from_dict(data: Mapping[str, Any], *, source: str = "<dict>") -> DatasetConfig:
    """Parse a configuration from the dict :meth:`DatasetConfig.to_dict` writes.

    Examples
    --------
    >>> cfg = loads_config("count = 4")
    >>> config_from_dict(cfg.to_dict()) == cfg
    True
    """
    return _Parser("", source).parse(data)


def list_examples() -> list[str]:
    """Names of the shipped example configurations.

    Examples
    --------
    >>> list_examples()
    ['planes', 'texture-sweep', 'flying']
    """
    return list(EXAMPLES)


def load_config(config: str | Path | DatasetConfig) -> DatasetConfig:
    """A configuration from a ``.toml`` path or the name of a shipped example.

    Parameters
    ----------
    config : str, Path or DatasetConfig
        A path to a TOML file, one of :data:`EXAMPLES` or an already parsed configuration
        (returned as is).

    Examples
    --------
    >>> load_config("planes").name
    'planes'
    """
    if isinstance(config, DatasetConfig):
        return config
    if not isinstance(config, (str, Path)):
        raise TypeError(f"config must be a path, an example name or a DatasetConfig, got "
                        f"{type(config).__name__}")
    path = Path(config)
    if path.suffix.lower() != ".toml" and str(config) in EXAMPLES:
        res = resources.files("synth.dataset") / "configs" / f"{config}.toml"
        return loads_config(res.read_text(encoding="utf-8"), source=f"{config}.toml")
    if not path.is_file():
        raise FileNotFoundError(f"dataset config {path} does not exist; pass a .toml file or "
                                f"one of the examples: {', '.join(EXAMPLES)}")
    return loads_config(path.read_text(encoding="utf-8"), source=str(path))
