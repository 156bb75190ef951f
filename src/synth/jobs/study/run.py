"""The texture-versus-window study: matcher accuracy and operations on controlled textures.

A study sweeps, over several seeds of generated scenes, the texture of every object (noise,
checker or stripes) at given **frequencies** (cycles per pixel at each object's reference depth
``Z``, its centre: ``f_m = f_px * fx / Z`` cycles per metre,
:func:`synth.appearance.texture_control.retexture`) or at given **edge densities** (closed loop,
:func:`synth.appearance.texture_control.match_edge_density`), times contrasts, times census window
sides and matcher methods. One *cell* is one rendered pair (scene kind, texture level, contrast,
seed), with photometric noise of ``noise_sigma`` grey levels drawn from a seed derived from the
cell; every method x window is run on it.

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
via :func:`synth.appearance.texture_control.edge_density`.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import json
import math
import os
import zlib
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from matcher.io import atomic_write_bytes
from stereoforge.errors import StereoforgeError
from synth._util.json_records import read_json_object
from synth._util.progress import progress as progress_bar
from synth.dataset.engine.tasks import run_tasks
from synth.formats import DEFAULT_FORMAT
from synth.jobs.study.config import (
    StudyConfig,
    StudyConfigError,
    list_studies,
    load_study_config,
    loads_study_config,
)
from synth.jobs.study.report import summarize, write_plots

__all__ = ["StudyConfig", "StudyConfigError", "COLUMNS", "load_study_config",
           "loads_study_config", "list_studies", "run_study", "summarize"]

#: Columns of ``results.csv``.
COLUMNS = ("kind", "texture_axis", "texture_level", "frequency_px", "contrast", "seed", "method",
           "window", "pobmp", "pobmp_all", "rms", "invalid", "census_comparisons",
           "hamming_words", "census_per_pixel", "ops_vs_ct", "edge_density")


# --------------------------------------------------------------------------- one cell
def _cell_path(cfg: StudyConfig, kind: str, level: float, contrast: float, seed: int) -> str:
    tag = {"frequency": "f", "edge_density": "e"}.get(cfg.axis, f"{cfg.axis}=")
    return f"cells/{kind}/{tag}{level:g}_c{contrast:g}_s{seed}.json"


def _fingerprint(cfg: StudyConfig, cell: tuple[str, float, float, int]) -> str:
    spec = {"cell": list(cell), "axis": cfg.axis, "texture": cfg.texture,
            "rig": cfg.rig.to_dict(), "noise_sigma": cfg.noise_sigma, "methods": cfg.methods,
            "windows": cfg.windows, "max_disparity": cfg.max_disparity, "delta": cfg.delta}
    if cfg.matchers:  # only then: the fingerprints of the built-in studies stay as they were
        spec["matchers"] = list(cfg.matchers)
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()


def _f(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _swept_sample(cfg: StudyConfig, kind: str, level: Any, contrast: float, seed: int,
                  renderer: Any) -> tuple:
    """A cell of a ``sweep_key`` study: the dataset config of the cell, its sample ``seed``."""
    from synth.dataset.config.sampling import effective_frequency_px
    from synth.validate.pairs import render_sample

    rig = cfg.rig
    config = {"seed": 0, "rig": {"width": rig.width, "height": rig.height, "fx": rig.fx,
                                 "baseline": rig.baseline},
              "scene": {"base": kind, "texture": cfg.texture, "contrast": contrast},
              "photometric": {"noise_sigma": cfg.noise_sigma}}
    section, _, key = cfg.axis.partition(".")
    config.setdefault(section, {})[key] = level
    pair, images, scene, _ = render_sample(config, seed, renderer)
    frequency = effective_frequency_px(scene, fx=rig.fx)
    return pair, images, scene, math.nan if frequency is None else frequency


_RESOLVED: dict[str, Any] = {}


def _user_matcher(spec: str) -> Any:
    """The resolved MATCHER string, one per process (a py: matcher keeps its child process)."""
    from matcher.adapters import resolve_matcher

    if spec not in _RESOLVED:
        _RESOLVED[spec] = resolve_matcher(spec)
    return _RESOLVED[spec]


def _kept(out: Path, index: int) -> Path:
    from synth.dataset.storage.layout import sample_dir

    return sample_dir(out / "pairs", DEFAULT_FORMAT, index)


def _keep_pair(out: Path, index: int, cfg: StudyConfig, record: dict, pair: Any, images: Any,
               scene: Any, seed: int) -> None:
    """Write the cell's pair (as the matchers saw it) to ``out/pairs/MiddEval3/trainingF/NNNNNN``
    (a dataset's layout) atomically, with a ``sample.json`` that
    :func:`synth.dataset.storage.manifest.read_manifest` reads."""
    import dataclasses
    import shutil

    from synth.write.export import write_pair

    from synth.dataset.storage.layout import sample_dir

    final = sample_dir(out / "pairs", DEFAULT_FORMAT, index)
    tmp = final.parent / f".{final.name}.tmp-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    try:
        degraded = dataclasses.replace(pair, left=images.left, right=images.right)
        write_pair(degraded, tmp, scene=scene, seed=seed, preview=False, fsync=False)
        sample = {"index": index, "seed": seed, "dir": final.name,
                  "params": {"kind": record["kind"], "texture_axis": record["texture_axis"],
                             "texture_level": record["texture_level"],
                             "contrast": record["contrast"], "noise_sigma": cfg.noise_sigma,
                             "max_disparity": cfg.max_disparity},
                  "stats": {"edge_density": record["edge_density"],
                            "frequency_px": record["frequency_px"]}}
        atomic_write_bytes(tmp / "sample.json", _json(sample), fsync=False)
        shutil.rmtree(final, ignore_errors=True)
        os.rename(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _compute_cell(cfg: StudyConfig, cell: tuple[str, float, float, int], renderer: Any,
                  keep: tuple[Path, int] | None = None) -> dict:
    from matcher import match
    from matcher.metrics import evaluate
    from scenes import get_preset
    from synth.pair import render_pair
    from synth.appearance.photometric import PhotometricParams, apply_photometric
    from synth.appearance.texture_control import edge_density, match_edge_density, retexture

    kind, level, contrast, seed = cell
    rig = cfg.rig
    if cfg.axis in ("frequency", "edge_density"):
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
    else:  # a dataset-config key: sample `seed` of that dataset config
        # (synth.dataset.config.sampling)
        pair, images, scene, frequency = _swept_sample(cfg, kind, level, contrast, seed, renderer)
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
    errors = {}
    for spec in cfg.matchers:
        outcome = _user_matcher(spec).run(images.left, images.right,
                                          max_disparity=cfg.max_disparity)
        disp = outcome.disparity
        if disp is None:  # a failure scores as no estimate anywhere; its message is kept
            errors[spec] = outcome.error
            disp = np.full(pair.disp_left.shape, np.inf, np.float32)
        m = evaluate(disp, pair.disp_left, delta=cfg.delta, region="nonocc",
                     occlusion_mask=pair.mask_left)
        m_all = evaluate(disp, pair.disp_left, delta=cfg.delta)
        rows.append({"method": spec, "window": None, "pobmp": m.pobmp, "pobmp_all": m_all.pobmp,
                     "rms": _f(m.rms), "invalid": m.invalid, "census_comparisons": None,
                     "hamming_words": None})
    for row in rows:
        c = row["census_comparisons"]
        row["census_per_pixel"] = None if c is None else c / pixels
        ref = ct_ops.get(row["window"])
        if ref is None and c is not None:  # CT not in the study: its count is closed-form
            from matcher import n_bits
            ref = 2 * pixels * n_bits(row["window"])
        row["ops_vs_ct"] = None if c is None else c / ref
    record = {"kind": kind, "texture_axis": cfg.axis, "texture_level": level,
              "frequency_px": float(frequency), "contrast": contrast, "seed": seed,
              "edge_density": rho, "rows": rows}
    if errors:
        record["matcher_errors"] = errors
    if keep is not None:
        _keep_pair(keep[0], keep[1], cfg, record, pair, images, scene, seed)
    return record


class _CellTask:
    """Picklable per-cell job for :func:`synth.dataset.engine.tasks.run_tasks`: computes and writes
    a cell."""

    def __init__(self, cfg: StudyConfig, out: Path, cells: list, backend: str,
                 threads: int | None, keep_pairs: bool = False) -> None:
        self.cfg, self.out, self.cells, self.threads = cfg, Path(out), cells, threads
        self.keep_pairs = keep_pairs
        self.width, self.height, self.backend = cfg.rig.width, cfg.rig.height, backend

    def __call__(self, index: int, renderer: Any) -> dict:
        if self.threads is not None:
            import numba

            numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))
        cell = self.cells[index]
        record = _compute_cell(self.cfg, cell, renderer,
                               (self.out, index) if self.keep_pairs else None)
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
        record = read_json_object(path, what="study cell")
    except (OSError, StereoforgeError):  # absent or damaged: computed again
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
              progress: bool = True, backend: str = "auto", matchers: Sequence[str] = (),
              keep_pairs: bool = False) -> Path:
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
        Show a progress bar on stderr (:func:`synth._util.progress.progress`).
    backend : {"auto", "egl", "osmesa"}
    matchers : sequence of str
        MATCHER strings (:func:`matcher.adapters.resolve_matcher`: ``py:...``, ``cmd:...``,
        ``ct:9``) run once on every cell's pair beside the config's methods x windows; their
        rows have ``method`` = the string and an empty ``window`` and census columns. A failure
        scores as "no estimate" (PoBMP 100) and its message is kept in the cell's JSON
        (``matcher_errors``). Not drawn in the heatmaps and summary tables (they are per window).
    keep_pairs : bool
        Also keep every cell's pair, as the matchers saw it, in ``out/pairs/MiddEval3/trainingF/NNNNNN/`` (MiddEval3
        folders with ``sample.json``; the index is the cell's): ``stereoforge eval-dataset
        out/pairs --matcher M`` scores another matcher on exactly these pairs later.

    Returns
    -------
    Path
        ``out``.
    """
    
    cfg = load_study_config(config)
    if matchers:
        from matcher.adapters import resolve_matcher

        specs = tuple(dict.fromkeys(str(m).strip() for m in matchers))
        for spec in specs:
            resolve_matcher(spec)  # a string that does not resolve fails here, once
        cfg = dataclasses.replace(cfg, matchers=specs)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an int >= 1, got {workers!r}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if cfg.text:
        atomic_write_bytes(out / "config.toml", cfg.text.encode(), fsync=False)
    cells = cfg.cells()
    prints = [_fingerprint(cfg, c) for c in cells]
    pending = [i for i, c in enumerate(cells)
               if _load_cell(out / _cell_path(cfg, *c), prints[i]) is None
               or (keep_pairs and not (_kept(out, i) / "sample.json").is_file())]
    threads = max(1, (os.cpu_count() or 1) // workers) if workers > 1 else None
    task = _CellTask(cfg, out, cells, backend, threads, keep_pairs)
    bar = progress_bar(total=len(cells), initial=len(cells) - len(pending), enabled=progress,
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
    write_plots(cfg, rows, out)
    return out
