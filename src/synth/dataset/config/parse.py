"""Dataset configurations: a TOML file of rig, scene distributions and photometric models.

A configuration is data (:class:`DatasetConfig`): fixed rig values plus, for every scene and
photometric parameter, a distribution (:class:`Dist`) that each sample draws from with its own
random generator. Every error names the file, the line of the offending key and the allowed
values (:exc:`ConfigError`). ``docs/datasets.md`` is the reference of every key.

Distributions are written as a plain value (fixed), ``{uniform = [a, b]}``,
``{loguniform = [a, b]}`` (``a > 0``) or ``{choice = [v1, v2, ...]}``. An integer key drawn from
``uniform``/``loguniform`` gives integers in ``[a, b]`` (both ends included).

The keys themselves (sections, types, bounds, docs) are :mod:`synth.dataset.config.keys`; this
module parses a file against them into a :class:`DatasetConfig` and draws its distributions.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping

from stereoforge.errors import ConfigError, StereoforgeError
from stereoforge.validation import check_input_file, check_keys, describe
from synth._util.toml_lines import TomlSource, parse_toml, read_toml_text
from synth.camera.lens import Defocus, Distortion, RigErrors
from synth.dataset.config.keys import (
    DIST_FORMS,
    DIST_KINDS,
    DIST_SECTIONS,
    DISTORTION_KEYS,
    EXAMPLES,
    GROUND_TRUTH_KINDS,
    IDEAL_RIG_KEYS,
    POSE_RIG_KEYS,
    PER_OBJECT_KEYS,
    SCHEMA,
    allowed_values,
)
from synth.camera.rig import StereoRig
from synth.dataset.config.dists import Dist
from synth.dataset.config.mix import load_parts
from synth.dataset.config.rig_draws import RIG_DRAW_KEYS, nominal, pose_problem

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
    "resized",
]

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
        The nominal rig: drawn keys at the middle of their distribution
        (:func:`synth.dataset.config.rig_draws.nominal`); a sample's own is its draw's ``rig``.
    rig_draws : Mapping[str, Dist]
        The ``[rig]`` keys drawn per sample (``baseline``, ``fx``; empty: one rig for all).
    redraw : int or None
        How many times a frame that teaches nothing is drawn again (``synth.dataset.sample``).
    parts : tuple of DatasetConfig
        A mix's parts (:mod:`synth.dataset.config.mix`; empty: no mix). A mix's ``rig`` is its
        first part's, its ``scene`` and ``photometric`` are empty.
    ground_truth : tuple of str
        Optional ground truth written with each sample (``synth.write.extra_ground_truth.GROUND_TRUTH``;
        empty by default).
    image_deflate : str or None
        The deflate of the images' PNGs (``matcher.io.encode_png``; ``None``: its default).
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
    ground_truth: tuple[str, ...] = ()
    image_deflate: str | None = None
    rig_draws: Mapping[str, Dist] = field(default_factory=lambda: MappingProxyType({}))
    redraw: int | None = None
    parts: tuple[DatasetConfig, ...] = ()

    def to_dict(self, *, with_count: bool = True) -> dict[str, Any]:
        """Canonical plain dict (the TOML structure, defaults filled in)."""
        if self.parts:  # a mix: its parts inline, no tables of its own
            out = {"name": self.name, "seed": self.seed, "preview": self.preview,
                   "mix": [p.to_dict(with_count=False) for p in self.parts]}
            out.update({k: v for k, v in (("ground_truth", list(self.ground_truth)),
                                          ("image_deflate", self.image_deflate),
                                          ("redraw", self.redraw)) if v})
            return {**out, "count": self.count} if with_count else out
        rig = {k: v for k, v in self.rig.to_dict().items() if k in IDEAL_RIG_KEYS}
        rig.update(_camera_keys(self.rig))
        if self.rig_draws:  # drawn per sample (rig_draws); absent: the hash is unchanged
            rig.update({k: d.to_toml() for k, d in self.rig_draws.items()})
            if "fx" in self.rig_draws:
                rig.pop("fy", None)  # fy follows the drawn fx
                if self.rig.fy != self.rig.fx:
                    rig["fy"] = self.rig.fy
        out: dict[str, Any] = {"name": self.name, "seed": self.seed, "preview": self.preview,
                               "rig": rig,
                               "scene": {k: d.to_toml() for k, d in sorted(self.scene.items())},
                               "photometric": {k: d.to_toml()
                                               for k, d in sorted(self.photometric.items())}}
        if self.ground_truth:  # absent by default: the hash of a config without it is unchanged
            out["ground_truth"] = list(self.ground_truth)
        if self.image_deflate is not None:  # the same
            out["image_deflate"] = self.image_deflate
        if self.redraw is not None:  # the same
            out["redraw"] = self.redraw
        if with_count:
            out["count"] = self.count
        return out

    def hash(self) -> str:
        """SHA-256 of the canonical configuration without ``count`` (which may grow)."""
        text = json.dumps(self.to_dict(with_count=False), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


class _Parser:
    """Checks the parsed TOML (or :meth:`DatasetConfig.to_dict`) against :data:`SCHEMA`."""

    def __init__(self, text: str, source: str) -> None:
        self.toml = TomlSource(text, source, ConfigError)
        self.source = source

    def fail(self, section: str, key: str, expected: str, actual: str, *,
             fix: str | None = None) -> ConfigError:
        return self.toml.fail(tuple(p for p in (section, key) if p), expected, actual, fix=fix)

    def scalar(self, section: str, key: str, value: Any, part: tuple[str, ...] = ()) -> Any:
        """One fixed value of ``section.key`` (``part`` names a bound or a choice of it)."""
        spec = SCHEMA[section][key]
        if isinstance(value, dict):
            raise self.fail(section, key, f"a fixed value: {spec.expected()}",
                            f"the table {value!r}",
                            fix=f"{key} takes a fixed value, not a distribution or table")
        dist_too = section in DIST_SECTIONS and not part and spec.kind in ("float", "int")
        path = (*(p for p in (section, key) if p), *part)
        return self.toml.check(spec, value, path, scalar=True,
                               fix=f"{DIST_FORMS} are allowed too" if dist_too else None)

    def dist(self, section: str, key: str, value: Any) -> Dist:
        spec = SCHEMA[section][key]
        if not isinstance(value, dict):
            if isinstance(value, list):
                raise self.fail(section, key, allowed_values(section, spec), f"the array {value!r}",
                                fix=f"write a distribution as {{choice = {value!r}}} or "
                                    "{uniform = [a, b]}")
            return Dist("fixed", (self.scalar(section, key, value),))
        if len(value) != 1 or next(iter(value)) not in DIST_KINDS:
            raise self.fail(section, key, f"a value or exactly one of {DIST_FORMS}", repr(value))
        kind, args = next(iter(value.items()))
        if not isinstance(args, list) or not args:
            raise self.fail(section, key, f"{{{kind} = [...]}} with a non-empty list",
                            f"{{{kind} = {args!r}}}")
        if kind == "choice":
            return Dist("choice", tuple(self.scalar(section, key, v, (f"choice[{i}]",))
                                        for i, v in enumerate(args)))
        if spec.kind not in ("float", "int"):
            raise self.fail(section, key, allowed_values(section, spec), repr(value),
                            fix=f"{key} is a {spec.kind}: only {{choice=[...]}} applies")
        if len(args) != 2:
            raise self.fail(section, key, f"{{{kind} = [a, b]}}", repr(value))
        a, b = (self.scalar(section, key, v, (f"{kind}[{i}]",)) for i, v in enumerate(args))
        if a > b:
            raise self.fail(section, key, f"{{{kind} = [a, b]}} with a <= b", f"[{a}, {b}]",
                            fix="swap the bounds")
        if kind == "loguniform" and a <= 0:
            raise self.fail(section, key, "{loguniform = [a, b]} with a > 0", f"[{a}, {b}]")
        return Dist(kind, (a, b), integer=spec.kind == "int")

    def keys(self, data: Mapping[str, Any], section: str, allowed: list[str], *,
             fix: str | None = None) -> None:
        """Every key of ``data`` is one of ``allowed`` (the error names the first other one)."""
        unknown = [k for k in data if k not in allowed]
        name = f"[{section}]" if section else "the top-level table"
        try:
            check_keys(data, name, allowed, fix=fix,
                       where=self.toml.where(*(p for p in (section, *unknown[:1]) if p)))
        except StereoforgeError as exc:
            raise self.toml.convert(exc) from None

    def section(self, data: Mapping[str, Any], section: str) -> dict[str, Any]:
        """The raw values of a table, its keys checked against the schema."""
        self.keys(data, section, list(SCHEMA[section]))
        return {k: data[k] for k in SCHEMA[section] if k in data}

    def meshes(self, scene: Mapping[str, Dist]) -> None:
        """'mesh' occluders have a mesh file, and every file named loads."""
        kinds = scene["occluder_kind"].args
        if "mesh" in kinds and "occluder_mesh" not in scene:
            raise self.fail("scene", "occluder_kind", "occluder_mesh beside a 'mesh' choice",
                            "no occluder_mesh", fix="add occluder_mesh = 'model.obj'")
        from scenes.assets import list_mesh_folder, load_mesh_file

        for value in scene["occluder_mesh"].args if "occluder_mesh" in scene else ():
            try:  # a folder's files are loaded when drawn (a ShapeNet tree is large)
                list_mesh_folder(value) if Path(value).is_dir() else load_mesh_file(value)
            except StereoforgeError as exc:
                raise self.fail("scene", "occluder_mesh", "a mesh file trimesh loads, or a "
                                "folder of them",
                                repr(value), fix=str(exc)) from None

    def per_object(self, scene: Mapping[str, Dist]) -> None:
        """The per-object texture keys go together and name known photographs."""
        given = [k for k in PER_OBJECT_KEYS if k in scene and k.startswith("object_")]
        if not given:
            return
        if "object_texture" not in scene:
            raise self.fail("scene", given[0], "object_texture beside it",
                            "no object_texture", fix="add object_texture = {choice = [...]}")
        if "edge_density" in scene:
            raise self.fail("scene", "edge_density", "edge_density or object_texture, not both",
                            "both", fix="edge_density sets one frequency for every object")
        kinds = scene["object_texture"].args if scene["object_texture"].kind != "fixed" else (
            scene["object_texture"].args[0],)
        if "image" in kinds and "object_image" not in scene:
            raise self.fail("scene", "object_texture", "object_image beside an 'image' choice",
                            "no object_image",
                            fix="add object_image = {choice = ['skimage:brick', ...]}")
        from scenes.spec import SKIMAGE_PHOTOS

        from scenes.assets import check_photo_source

        for value in scene["object_image"].args if "object_image" in scene else ():
            if value.startswith("skimage:") and value[8:] not in SKIMAGE_PHOTOS:
                raise self.fail("scene", "object_image", f"skimage:<name> with a name in "
                                f"{list(SKIMAGE_PHOTOS)}", repr(value))
            try:  # a folder without images, a damaged or huge file: refused now, not at sample 0
                check_photo_source(value)
            except StereoforgeError as exc:
                raise self.fail("scene", "object_image", "a photograph (skimage:<name>, an "
                                "image file or a folder of them)", repr(value),
                                fix=str(exc)) from None

    def mix(self, data: Mapping[str, Any], top: Mapping[str, Any], name: str) -> DatasetConfig:
        """A mix of configurations (:mod:`synth.dataset.config.mix`): its parts, its top level."""
        own = [t for t in SCHEMA if t and t in data]
        if own:
            raise self.fail("", own[0], "no table beside mix", f"[{own[0]}]",
                            fix="a mix draws its rig, scenes and photometry from its parts: "
                                "put the table in a part")
        parts = load_parts(data["mix"], self.source, load=load_config, from_dict=config_from_dict)
        return DatasetConfig(
            name=name, seed=top.get("seed", 0), count=top.get("count", 10),
            preview=top.get("preview", False), rig=parts[0].rig, scene=MappingProxyType({}),
            photometric=MappingProxyType({}), source=self.source,
            ground_truth=tuple(k for k in GROUND_TRUTH_KINDS if k in (top.get("ground_truth") or ())),
            image_deflate=top.get("image_deflate"), redraw=top.get("redraw"), parts=parts)

    def parse(self, data: Mapping[str, Any]) -> DatasetConfig:
        if not isinstance(data, Mapping):
            raise ConfigError(f"{self.source}: a configuration is a table, got "
                              f"{type(data).__name__}")
        tables = [s for s in SCHEMA if s]
        for key, value in data.items():
            if key in tables and not isinstance(value, Mapping):
                raise self.fail("", key, f"a table [{key}]", describe(value))
        self.keys(data, "", [*SCHEMA[""], *tables],
                  fix=f"the tables are {', '.join(f'[{t}]' for t in tables)}")
        top = {k: self.scalar("", k, v) for k, v in data.items()
               if k in SCHEMA[""] and not SCHEMA[""][k].array}
        if "ground_truth" in data:  # an array key
            top["ground_truth"] = self.toml.check(SCHEMA[""]["ground_truth"],
                                                  data["ground_truth"], ("ground_truth",))
        name = top.get("name", Path(self.source).stem if self.source != "<string>" else "dataset")
        if "mix" in data:
            return self.mix(data, top, name)
        raw_rig = self.section(data.get("rig", {}), "rig")
        rig_draws = {k: self.dist("rig", k, raw_rig[k]) for k in RIG_DRAW_KEYS if isinstance(
            raw_rig.get(k), dict) or (k in POSE_RIG_KEYS and k in raw_rig)}  # pose: always
        rig_kw = {k: nominal(rig_draws[k]) if k in rig_draws else self.scalar("rig", k, v)
                  for k, v in raw_rig.items()}
        rig_kw = {k: rig_kw.get(k, SCHEMA["rig"][k].default) for k in SCHEMA["rig"]}
        fx = rig_kw["fx"] if rig_kw["fx"] is not None else 600.0 * rig_kw["width"] / 640.0
        if not rig_kw["near"] < rig_kw["far"]:
            raise self.fail("rig", "far", "near < far",
                            f"near = {rig_kw['near']}, far = {rig_kw['far']}",
                            fix="put the far plane beyond the near plane")
        fy = rig_kw["fy"] if rig_kw["fy"] is not None else fx
        try:
            rig = StereoRig(width=rig_kw["width"], height=rig_kw["height"], fx=fx, fy=fy,
                            cx=(rig_kw["width"] - 1) / 2.0, cy=(rig_kw["height"] - 1) / 2.0,
                            baseline=rig_kw["baseline"], near=rig_kw["near"],
                            far=rig_kw["far"], errors=_rig_errors(rig_kw))
        except StereoforgeError as exc:
            first = next((k for k in SCHEMA["rig"] if k not in (*IDEAL_RIG_KEYS, *POSE_RIG_KEYS)
                          and rig_kw[k] is not None), "width")
            raise ConfigError(f"{self.toml.where('rig', first)}: [rig] {exc}") from None
        sections = {}
        for sec in DIST_SECTIONS:
            raw = self.section(data.get(sec, {}), sec)
            out = {}
            for key, spec in SCHEMA[sec].items():
                if key in raw:
                    out[key] = self.dist(sec, key, raw[key])
                elif not spec.optional:
                    out[key] = Dist("fixed", (spec.default,))
            sections[sec] = out
        scene = sections["scene"]
        if "edge_density" in scene and "frequency_px" in scene:
            raise self.fail("scene", "edge_density", "edge_density or frequency_px, not both",
                            "both", fix="they exclude each other: edge_density chooses the "
                                        "frequency; remove one")
        if "edge_density" in scene and scene["texture"].to_toml() == "constant":
            raise self.fail("scene", "edge_density", "a textured surface",
                            "texture = 'constant', which has none",
                            fix="choose another texture or remove edge_density")
        if (problem := pose_problem(rig_draws, scene["base"])) is not None:
            raise self.fail("rig", "camera_height", *problem[:2], fix=problem[2])
        self.per_object(scene)
        self.meshes(scene)
        if "occluder_each" in scene and scene["occluder_each"].kind != "fixed":
            raise self.fail("scene", "occluder_each", "true or false",
                            str(scene["occluder_each"].to_toml()),
                            fix="one value for the whole dataset: draw the occluders' kinds, "
                                "sizes and depths with their own keys")
        return DatasetConfig(
            rig_draws=MappingProxyType(rig_draws),
            name=name, seed=top.get("seed", 0), count=top.get("count", 10),
            preview=top.get("preview", False), rig=rig,
            scene=MappingProxyType(scene), photometric=MappingProxyType(sections["photometric"]),
            source=self.source,
            ground_truth=tuple(k for k in GROUND_TRUTH_KINDS if k in (top.get("ground_truth") or ())),
            image_deflate=top.get("image_deflate"), redraw=top.get("redraw"),
        )


def _rig_errors(kw: Mapping[str, Any]) -> RigErrors | None:
    """The camera errors of the ``[rig]`` keys (``None`` when none is set: the ideal rig)."""
    if all(kw[k] is None for k in SCHEMA["rig"]
           if k not in (*IDEAL_RIG_KEYS, *POSE_RIG_KEYS, "fy")):
        return None
    if (kw["focus_distance"] is None) != (kw["f_number"] is None):
        raise ConfigError("focus_distance and f_number: expected both (defocus) or neither, "
                          "got one; set both to blur by depth, or remove the one set")

    def dist(prefix: str) -> Distortion:
        return Distortion(*(kw[f"{prefix}{k}"] or 0.0 for k in DISTORTION_KEYS))

    defocus = None if kw["focus_distance"] is None else Defocus(
        kw["focus_distance"], kw["f_number"],
        3.0 if kw["pixel_pitch_um"] is None else kw["pixel_pitch_um"])
    return RigErrors(left=dist(""), right=dist("right_"),
                     rotation_deg=tuple(kw[f"right_{a}_deg"] or 0.0 for a in ("rx", "ry", "rz")),
                     dy_px=kw["right_dy_px"] or 0.0,
                     f_scale=1.0 if kw["right_f_scale"] is None else kw["right_f_scale"],
                     defocus=defocus)


def _camera_keys(rig: StereoRig) -> dict[str, Any]:
    """The ``[rig]`` keys of ``rig``'s real cameras that differ from the ideal rig."""
    out: dict[str, Any] = {} if rig.fy == rig.fx else {"fy": rig.fy}
    e = rig.errors
    if e is None:
        return out
    values = {**{k: v for k, v in zip(DISTORTION_KEYS, e.left.coeffs)},
              **{f"right_{k}": v for k, v in zip(DISTORTION_KEYS, e.right.coeffs)},
              **{f"right_{a}_deg": v for a, v in zip(("rx", "ry", "rz"), e.rotation_deg)},
              "right_dy_px": e.dy_px, "right_f_scale": e.f_scale}
    out.update({k: v for k, v in values.items()
                if v != (1.0 if k == "right_f_scale" else 0.0)})
    if e.defocus is not None:
        out.update(focus_distance=e.defocus.focus_distance, f_number=e.defocus.f_number,
                   pixel_pitch_um=e.defocus.pixel_pitch_um)
    return out


def loads_config(text: str, *, source: str = "<string>") -> DatasetConfig:
    """Parse a configuration from TOML text.

    Raises
    ------
    ConfigError
        ``source:line: table.key: expected ..., got ...; fix`` for a value of the wrong type or
        out of range, ``source:line: unknown key ...; valid keys: ...`` for an unknown key,
        ``source: invalid TOML: ...`` for a syntax error.

    Examples
    --------
    >>> loads_config("[scene]\\nocluders = 2\\n", source="my.toml")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    stereoforge.errors.ConfigError: my.toml:2: unknown key 'ocluders' in [scene]; valid keys: ['base', ...]; did you mean 'occluders'?
    >>> loads_config("[rig]\\nwidth = 4\\n", source="my.toml")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ConfigError: my.toml:2: rig.width: expected an integer in [8, 8192], got 4
    """
    return _Parser(text, source).parse(parse_toml(text, source))


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
    >>> list_examples()[:5]
    ['planes', 'texture-sweep', 'flying', 'imperfect-rig', 'middlebury-like']
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
    check_input_file(path, "dataset config", suffixes=(".toml",),
                     fix=f"pass a .toml file or one of the examples: {', '.join(EXAMPLES)}")
    return loads_config(read_toml_text(path), source=str(path))


def resized(config: DatasetConfig, width: int, height: int) -> DatasetConfig:
    """``config`` rendering ``width x height`` pixels, ``fx`` scaled with the width.

    Examples
    --------
    >>> cfg = resized(load_config("flying"), 960, 540)
    >>> cfg.rig.width, cfg.rig.height, cfg.rig.fx
    (960, 540, 900.0)
    """
    if config.parts:
        data = config.to_dict()
        data["mix"] = [resized(p, width, height).to_dict(with_count=False) for p in config.parts]
        return config_from_dict(data, source=f"{config.source} at {width}x{height}")
    data = config.to_dict()
    scale = width / config.rig.width
    fx = config.rig_draws.get("fx")
    data["rig"] = {**data["rig"], "width": int(width), "height": int(height),
                   "fx": config.rig.fx * scale if fx is None else
                   Dist(fx.kind, tuple(a * scale for a in fx.args)).to_toml()}
    return config_from_dict(data, source=f"{config.source} at {width}x{height}")
