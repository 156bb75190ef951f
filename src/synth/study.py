"""The texture-versus-window study: matcher accuracy and operations on controlled textures.

A study sweeps, over several seeds of generated scenes, the texture of every object (noise,
checker or stripes) at given **frequencies** (cycles per pixel at each object's reference depth
``Z``, its centre: ``f_m = f_px * fx / Z`` cycles per metre, :func:`synth.texture_control.retexture`)
or at given **edge densities** (closed loop, :func:`synth.texture_control.match_edge_density`),
times contrasts, times census window sides and matcher methods. One *cell* is one rendered pair
(scene kind, texture level, contrast, seed), with photometric noise of ``noise_sigma`` grey levels
drawn from a seed derived from the cell; every method x window is run on it.

Outputs in ``out``:

- ``cells/<kind>/<level>_c<contrast>_s<seed>.json``: one per cell, written atomically, with a
  fingerprint of everything that determines it; a rerun skips cells whose fingerprint matches
  (resumable) and recomputes the rest;
- ``results.csv``: one row per kind x texture level x contrast x seed x method x window (column
  list :data:`COLUMNS`), rebuilt from the cells in a fixed order, so the same config gives the
  same bytes;
- ``summary.md``: means with 95 % t-intervals (``mean +- t(0.975, n-1) s / sqrt(n)`` over the
  cells of a group: kinds and seeds pooled), and paired AWCT-CT and CTHW-CT differences;
- ``pobmp_heatmap.png`` (PoBMP over texture level x window, one panel per method and contrast),
  ``ops_accuracy.png`` (census comparisons per pixel against PoBMP) and ``config.toml``.

Accuracy is measured on non-occluded pixels (``region="nonocc"``, ``pobmp``): the band of left
pixels whose match lies outside the right image is bad for every method whatever the texture;
``pobmp_all`` (the paper's "all pixels with ground truth") is in the CSV too. Edge density is the
fraction of Canny edge pixels of the left image the matchers see (after the photometric noise),
:func:`matcher.edges.canny_edges` with its defaults (sigma 1, thresholds 0.1 / 0.2 of the range),
via :func:`synth.texture_control.edge_density`.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import tomllib
import zlib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from synth._toml import line_of
from synth.engine import run_tasks
from synth.io._atomic import atomic_write_bytes, save_figure_atomic
from synth.rig import StereoRig

__all__ = ["StudyConfig", "StudyConfigError", "COLUMNS", "load_study_config",
           "loads_study_config", "list_studies", "run_study", "summarize"]

#: Columns of ``results.csv``.
COLUMNS = ("kind", "texture_axis", "texture_level", "frequency_px", "contrast", "seed", "method",
           "window", "pobmp", "pobmp_all", "rms", "invalid", "census_comparisons",
           "hamming_words", "census_per_pixel", "ops_vs_ct", "edge_density")
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
    """Names of the shipped study configurations (``src/synth/configs/study-*.toml``).

    Examples
    --------
    >>> "study-texture-window" in list_studies()
    True
    """
    folder = resources.files("synth") / "configs"
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
            res = resources.files("synth") / "configs" / f"{candidate}.toml"
            return loads_study_config(res.read_text(encoding="utf-8"), source=f"{candidate}.toml")
    path = Path(config)
    if not path.is_file():
        raise FileNotFoundError(f"study config {path} does not exist; pass a .toml file or one "
                                f"of the shipped studies: {', '.join(shipped)}")
    return loads_study_config(path.read_text(encoding="utf-8"), source=str(path))


# --------------------------------------------------------------------------- one cell
def _cell_path(cfg: StudyConfig, kind: str, level: float, contrast: float, seed: int) -> str:
    tag = "f" if cfg.axis == "frequency" else "e"
    return f"cells/{kind}/{tag}{level:g}_c{contrast:g}_s{seed}.json"


def _fingerprint(cfg: StudyConfig, cell: tuple[str, float, float, int]) -> str:
    spec = {"cell": list(cell), "axis": cfg.axis, "texture": cfg.texture,
            "rig": cfg.rig.to_dict(), "noise_sigma": cfg.noise_sigma, "methods": cfg.methods,
            "windows": cfg.windows, "max_disparity": cfg.max_disparity, "delta": cfg.delta}
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()


def _f(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _compute_cell(cfg: StudyConfig, cell: tuple[str, float, float, int], renderer: Any) -> dict:
    from matcher import match
    from matcher.metrics import evaluate
    from scenes import get_preset
    from synth.pair import render_pair
    from synth.photometric import PhotometricParams, apply_photometric
    from synth.texture_control import edge_density, match_edge_density, retexture

    kind, level, contrast, seed = cell
    rig = cfg.rig
    scene = retexture(get_preset(kind, seed=seed), fx=rig.fx, contrast=contrast,
                      kind=cfg.texture, frequency_px=level if cfg.axis == "frequency" else None)
    frequency = level
    if cfg.axis == "edge_density":
        search = match_edge_density(scene, rig, level, renderer=renderer)
        scene, frequency = search.scene, search.frequency_px
    pair = render_pair(scene, rig, renderer=renderer)
    noise_seed = [seed, zlib.crc32(f"{kind}/{level!r}/{contrast!r}".encode())]
    images = apply_photometric(pair.left, pair.right,
                               PhotometricParams(noise_sigma=cfg.noise_sigma), rng=noise_seed)
    rho = edge_density(images.left)
    pixels = rig.width * rig.height
    rows = []
    ct_ops: dict[int, int] = {}
    for method in cfg.methods:
        for window in cfg.windows:
            res = match(images.left, images.right, method=method, window=window,
                        max_disparity=cfg.max_disparity)
            m = evaluate(res.disparity, pair.disp_left, delta=cfg.delta, region="nonocc",
                         occlusion_mask=pair.mask_left)
            m_all = evaluate(res.disparity, pair.disp_left, delta=cfg.delta)
            ops = res.ops
            if method == "ct" and ops is not None:
                ct_ops[window] = ops.census_comparisons
            rows.append({
                "method": method, "window": window, "pobmp": m.pobmp, "pobmp_all": m_all.pobmp,
                "rms": _f(m.rms), "invalid": m.invalid,
                "census_comparisons": None if ops is None else int(ops.census_comparisons),
                "hamming_words": None if ops is None else int(ops.hamming_words),
            })
    for row in rows:
        c = row["census_comparisons"]
        row["census_per_pixel"] = None if c is None else c / pixels
        ref = ct_ops.get(row["window"])
        if ref is None and c is not None:  # CT not in the study: its count is closed-form
            from matcher.census import n_bits
            ref = 2 * pixels * n_bits(row["window"])
        row["ops_vs_ct"] = None if c is None else c / ref
    return {"kind": kind, "texture_axis": cfg.axis, "texture_level": level,
            "frequency_px": float(frequency), "contrast": contrast, "seed": seed,
            "edge_density": rho, "rows": rows}


class _CellTask:
    """Picklable per-cell job for :func:`synth.engine.run_tasks`: computes and writes a cell."""

    def __init__(self, cfg: StudyConfig, out: Path, cells: list, backend: str,
                 threads: int | None) -> None:
        self.cfg, self.out, self.cells, self.threads = cfg, Path(out), cells, threads
        self.width, self.height, self.backend = cfg.rig.width, cfg.rig.height, backend

    def __call__(self, index: int, renderer: Any) -> dict:
        if self.threads is not None:
            import numba

            numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))
        cell = self.cells[index]
        record = _compute_cell(self.cfg, cell, renderer)
        record["fingerprint"] = _fingerprint(self.cfg, cell)
        path = self.out / _cell_path(self.cfg, *cell)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(path, _json(record), fsync=False)
        return {"path": str(path)}


def _json(obj: Any) -> bytes:
    return (json.dumps(obj, indent=1, sort_keys=True, allow_nan=False) + "\n").encode()


# --------------------------------------------------------------------------- the run
def _load_cell(path: Path, fingerprint: str) -> dict | None:
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return record if record.get("fingerprint") == fingerprint else None


def _results_csv(cfg: StudyConfig, records: list[dict]) -> bytes:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for rec in records:
        for row in rec["rows"]:
            full = {**rec, **row}
            writer.writerow(["" if full[c] is None else repr(full[c])
                             if isinstance(full[c], float) else full[c] for c in COLUMNS])
    return buf.getvalue().encode()


def run_study(config: str | Path | StudyConfig, *, out: str | Path, workers: int = 1,
              progress: bool = True, backend: str = "auto") -> Path:
    """Run a study (resumable) and write its results, summary and plots into ``out``.

    Parameters
    ----------
    config : str, Path or StudyConfig
        See :func:`load_study_config`.
    out : str or Path
        Output folder (created); cells already computed there with the same settings are kept.
    workers : int
        Worker processes (one GL renderer each; ``1`` runs in this process).
    progress : bool
        Show a tqdm progress bar on stderr.
    backend : {"auto", "egl", "osmesa"}

    Returns
    -------
    Path
        ``out``.
    """
    from tqdm import tqdm

    cfg = load_study_config(config)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an int >= 1, got {workers!r}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if cfg.text:
        atomic_write_bytes(out / "config.toml", cfg.text.encode(), fsync=False)
    cells = cfg.cells()
    prints = [_fingerprint(cfg, c) for c in cells]
    pending = [i for i, c in enumerate(cells)
               if _load_cell(out / _cell_path(cfg, *c), prints[i]) is None]
    threads = max(1, (os.cpu_count() or 1) // workers) if workers > 1 else None
    task = _CellTask(cfg, out, cells, backend, threads)
    bar = tqdm(total=len(cells), initial=len(cells) - len(pending), disable=not progress,
               desc=f"study {cfg.name}", unit="cell")
    try:
        for _ in run_tasks(task, pending, workers=workers):
            bar.update(1)
    finally:
        bar.close()
    records = []
    for i, c in enumerate(cells):
        rec = _load_cell(out / _cell_path(cfg, *c), prints[i])
        if rec is None:
            raise RuntimeError(f"cell {_cell_path(cfg, *c)} is missing after the run")
        records.append(rec)
    atomic_write_bytes(out / "results.csv", _results_csv(cfg, records), fsync=False)
    rows = [{**rec, **row} for rec in records for row in rec["rows"]]
    atomic_write_bytes(out / "summary.md", summarize(cfg, rows).encode(), fsync=False)
    _plots(cfg, rows, out)
    return out


# --------------------------------------------------------------------------- summary
def _interval(values: list[float]) -> tuple[float, float, int]:
    """``(mean, half width of the 95 % t-interval, n)``; half width NaN when n < 2."""
    v = np.asarray([x for x in values if x is not None], dtype=np.float64)
    n = v.size
    if n == 0:
        return math.nan, math.nan, 0
    if n < 2:
        return float(v.mean()), math.nan, 1
    from scipy.stats import t

    return float(v.mean()), float(t.ppf(0.975, n - 1) * v.std(ddof=1) / math.sqrt(n)), n


def _fmt(mean: float, half: float, digits: int = 1) -> str:
    if math.isnan(mean):
        return "–"
    if math.isnan(half):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {half:.{digits}f}"


def _level_label(cfg: StudyConfig, level: float) -> str:
    return f"f={level:g}" if cfg.axis == "frequency" else f"ρ={level:g}"


def _table(header: list[str], body: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *["| " + " | ".join(r) + " |" for r in body], ""]


def _paired(rows: list[dict], a: str, b: str) -> dict[tuple, list[tuple[float, float, dict]]]:
    """``(kind, window, level, contrast) -> [(pobmp_a - pobmp_b, census_a / census_b, row_a)]``."""
    index = {(r["kind"], r["texture_level"], r["contrast"], r["seed"], r["method"], r["window"]): r
             for r in rows}
    out: dict[tuple, list[tuple[float, float, dict]]] = {}
    for key, ra in index.items():
        if key[4] != a:
            continue
        rb = index.get((*key[:4], b, key[5]))
        if rb is None:
            continue
        ratio = (ra["census_comparisons"] / rb["census_comparisons"]
                 if ra["census_comparisons"] and rb["census_comparisons"] else math.nan)
        out.setdefault((key[0], key[5], key[1], key[2]), []).append(
            (ra["pobmp"] - rb["pobmp"], ratio, ra))
    return out


#: Edge-density bins (fractions) of the summary's per-density table.
_RHO_BINS = (0.0, 0.02, 0.05, 0.10, 0.20, 0.30, 1.0)


def _density_table(cfg: StudyConfig, pairs: dict, a: str, b: str) -> list[str]:
    """Paired differences binned by measured edge density, kinds and levels pooled."""
    lines = [f"### {a.upper()} − {b.upper()} by measured edge density (all scenes, levels, "
             "contrasts)", "",
             "Each entry: PoBMP difference in points (95 % t-interval) / census comparisons of "
             f"{a.upper()} as % of {b.upper()}'s; n pairs in brackets.", ""]
    bins = list(zip(_RHO_BINS[:-1], _RHO_BINS[1:]))
    body = []
    for w in cfg.windows:
        entry = [str(w)]
        for lo, hi in bins:
            sel = [(d, r) for (kind, win, lv, c), v in pairs.items() if win == w
                   for d, r, row in v if lo <= row["edge_density"] < hi]
            if not sel:
                entry.append("–")
                continue
            m, h, n = _interval([d for d, _ in sel])
            entry.append(f"{_fmt(m, h, 2)} / {100 * float(np.mean([r for _, r in sel])):.1f} % "
                         f"({n})")
        body.append(entry)
    return lines + _table(["window", *[f"ρ {100 * lo:g}–{100 * hi:g} %" for lo, hi in bins]],
                          body)


def summarize(cfg: StudyConfig, rows: list[dict]) -> str:
    """``summary.md`` of a study from its result rows (the dicts behind ``results.csv``).

    Every entry is ``mean ± half width`` of the 95 % t-interval over the seeds of its group
    (one scene kind, texture level, contrast, method and window), except the tables by edge
    density, which pool every pair whose measured density falls in the bin.
    """
    levels, contrasts = cfg.levels, cfg.contrasts
    labels = [_level_label(cfg, lv) for lv in levels]
    what = ("cycles per pixel at each object's centre depth" if cfg.axis == "frequency"
            else "target edge density")
    lines = [f"# Study `{cfg.name}`", "", cfg.description.strip(), "",
             f"- rig: {cfg.rig.width} x {cfg.rig.height}, fx = {cfg.rig.fx:g} px, baseline = "
             f"{cfg.rig.baseline:g} m; max_disparity = {cfg.max_disparity}, delta = {cfg.delta:g}",
             f"- scenes: {', '.join(cfg.kinds)}; seeds {', '.join(map(str, cfg.seeds))}; "
             f"texture `{cfg.texture}`, contrasts {', '.join(f'{c:g}' for c in contrasts)}, "
             f"noise sigma {cfg.noise_sigma:g} grey levels",
             f"- texture levels ({what}): {', '.join(f'{lv:g}' for lv in levels)}",
             f"- methods {', '.join(cfg.methods)}; windows {', '.join(map(str, cfg.windows))}",
             f"- {len(cfg.cells())} rendered pairs, {len(rows)} rows; each entry: mean ± half "
             f"width of the 95 % t-interval over the n = {len(cfg.seeds)} seeds "
             "(t(0.975, n − 1) s / sqrt(n))",
             "- PoBMP: % of non-occluded pixels with |error| > delta or no estimate",
             "- ρ: fraction of Canny edge pixels of the matched left image "
             "(matcher.edges.canny_edges defaults: sigma 1, thresholds 0.1 / 0.2)", ""]
    groups: dict[tuple, list[float]] = {}
    for r in rows:
        groups.setdefault((r["kind"], r["method"], r["window"], r["texture_level"], r["contrast"]),
                          []).append(r["pobmp"])
    first = [r for r in rows if r["method"] == cfg.methods[0] and r["window"] == cfg.windows[0]]
    lines += ["## Measured edge density ρ (%)", ""]
    body = []
    for kind in cfg.kinds:
        for c in contrasts:
            body.append([kind, f"{c:g}", *[_fmt(*_interval(
                [100 * r["edge_density"] for r in first if r["kind"] == kind
                 and r["contrast"] == c and r["texture_level"] == lv])[:2], 2) for lv in levels]])
    lines += _table(["scene", "contrast", *labels], body)
    if cfg.axis == "edge_density":
        lines += ["Frequencies found (cycles/px): " + ", ".join(
            f"{label}: {_fmt(*_interval([r['frequency_px'] for r in first if r['texture_level'] == lv])[:2], 4)}"
            for lv, label in zip(levels, labels)), ""]
    for kind in cfg.kinds:
        for c in contrasts:
            lines += [f"## PoBMP (%), {kind}, contrast {c:g}", ""]
            body = [[f"{m} {w}", *[_fmt(*_interval(groups.get((kind, m, w, lv, c), []))[:2])
                                   for lv in levels]] for m in cfg.methods for w in cfg.windows]
            lines += _table(["method window", *labels], body)
    for a, b in (("awct", "ct"), ("awsct", "sct"), ("cthw", "ct")):
        if a not in cfg.methods or b not in cfg.methods:
            continue
        pairs = _paired(rows, a, b)
        lines += [f"## {a.upper()} − {b.upper()} (paired: same pair, same window)", "",
                  f"Each entry: PoBMP difference in points / census comparisons of {a.upper()} "
                  f"as % of {b.upper()}'s at the same window.", ""]
        for kind in cfg.kinds:
            for c in contrasts:
                lines += [f"### {kind}, contrast {c:g}", ""]
                body = []
                for w in cfg.windows:
                    entry = [str(w)]
                    for lv in levels:
                        p = pairs.get((kind, w, lv, c), [])
                        entry.append(f"{_fmt(*_interval([x for x, _, _ in p])[:2], 2)} / "
                                     f"{_interval([100 * y for _, y, _ in p])[0]:.1f} %")
                    body.append(entry)
                lines += _table(["window", *labels], body)
        lines += _density_table(cfg, pairs, a, b)
    return "\n".join(lines).rstrip() + "\n"


# --------------------------------------------------------------------------- plots
def _plots(cfg: StudyConfig, rows: list[dict], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [f"{lv:g}" for lv in cfg.levels]
    xlabel = "texture frequency (cycles/px)" if cfg.axis == "frequency" else "edge density target"
    mean: dict[tuple, float] = {}
    groups: dict[tuple, list[float]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["window"], r["texture_level"], r["contrast"]),
                          []).append(r["pobmp"])
    for k, v in groups.items():
        mean[k] = float(np.mean(v))
    vmax = max(mean.values()) if mean else 100.0
    nr, nc = len(cfg.contrasts), len(cfg.methods)
    fig, axes = plt.subplots(nr, nc, figsize=(2.6 * nc + 1, 2.4 * nr + 0.6), squeeze=False,
                             sharex=True, sharey=True, layout="constrained")
    im = None
    for i, c in enumerate(cfg.contrasts):
        for j, m in enumerate(cfg.methods):
            grid = np.array([[mean.get((m, w, lv, c), np.nan) for lv in cfg.levels]
                             for w in cfg.windows])
            ax = axes[i, j]
            im = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis_r", vmin=0,
                           vmax=vmax)
            for (yy, xx), v in np.ndenumerate(grid):
                if np.isfinite(v):
                    ax.text(xx, yy, f"{v:.0f}", ha="center", va="center", fontsize=6,
                            color="white" if v > 0.6 * vmax else "black")
            ax.set_title(f"{m.upper()}, contrast {c:g}", fontsize=8)
            ax.set_xticks(range(len(labels)), labels, fontsize=6, rotation=45)
            ax.set_yticks(range(len(cfg.windows)), [str(w) for w in cfg.windows], fontsize=6)
            if i == nr - 1:
                ax.set_xlabel(xlabel, fontsize=7)
            if j == 0:
                ax.set_ylabel("window", fontsize=7)
    fig.colorbar(im, ax=axes, shrink=0.8, label="PoBMP (%, non-occluded)")
    save_figure_atomic(fig, out / "pobmp_heatmap.png", dpi=110)
    plt.close(fig)

    n = len(cfg.levels)
    cols = min(n, 3)
    fig, axes = plt.subplots(math.ceil(n / cols), cols, figsize=(4.2 * cols, 3.3 * math.ceil(n / cols)),
                             squeeze=False, sharey=True)
    for k, lv in enumerate(cfg.levels):
        ax = axes[k // cols, k % cols]
        for m in cfg.methods:
            sel = [r for r in rows if r["method"] == m and r["texture_level"] == lv]
            pts = []
            for w in cfg.windows:
                ws = [r for r in sel if r["window"] == w]
                if ws:
                    ops = [r["census_per_pixel"] for r in ws]
                    pts.append((None if ops[0] is None else float(np.mean(ops)),
                                float(np.mean([r["pobmp"] for r in ws]))))
            if pts and pts[0][0] is None:
                best = min(p[1] for p in pts)
                ax.axhline(best, ls="--", lw=1, color="grey", label=f"{m.upper()} (best window)")
                continue
            adaptive = m.startswith("aw")
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "x--" if adaptive else "o-",
                    ms=5 if adaptive else 3, lw=1, label=m.upper())
        ax.set_xscale("log")
        ax.set_title(_level_label(cfg, lv), fontsize=9)
        ax.set_xlabel("census comparisons per pixel (both views)", fontsize=7)
        ax.set_ylabel("PoBMP (%, non-occluded)", fontsize=7)
        ax.tick_params(labelsize=6)
    for k in range(n, axes.size):
        axes.flat[k].axis("off")
    axes[0, 0].legend(fontsize=6)
    fig.suptitle(f"operations against accuracy (windows {cfg.windows[0]}..{cfg.windows[-1]}; "
                 "mean over scenes, contrasts, seeds)", fontsize=9)
    fig.tight_layout()
    save_figure_atomic(fig, out / "ops_accuracy.png", dpi=110)
    plt.close(fig)
