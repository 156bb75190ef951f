"""Datasets at scale: many labelled pairs from one configuration, deterministic and resumable.

Layout of a dataset directory ``out/``::

    dataset.json        configuration (canonical), its hash, format, Canny settings
    manifest.jsonl      one JSON record per complete sample, sorted by index
    manifest.csv        the same records, flattened (``params.*``, ``stats.*`` columns)
    MiddEval3/trainingF/000000/   sample 0: im0.png im1.png disp0GT.pfm ... calib.txt
                        scene.json sample.json [preview.png]          (fmt="middlebury")
    MiddEval3/official_train.txt  the complete samples' names (RAFT-Stereo's Middlebury loader)
    training/samples/000000/      scene.json sample.json; the images go to  (fmt="kitti")
    training/image_2/ image_3/ disp_occ_0/ disp_noc_0/ obj_map/   000000_10.png ...
    training/calib_cam_to_cam/                                    000000.txt
    .lock               held (flock) by the run writing the directory

Guarantees (see ``docs/datasets.md``):

- sample ``i`` depends only on the configuration and ``i`` (its seed is
  :func:`synth.dataset.sampling.sample_seed`), so its files are byte-identical whatever the number of
  workers, the engine or the order;
- a sample is written into ``.NNNNNN.tmp-<pid>/`` and renamed to its folder (above; see
  :mod:`synth.dataset.layout`); its completion record ``records/NNNNNN.json`` (every file with
  size and SHA-256, :mod:`synth.dataset.integrity`) is written last.
  A run killed at any point and restarted skips the samples whose record exists and whose files
  have the recorded sizes, renders the others again (an emptied folder, a truncated file) and
  ends with the same bytes as an uninterrupted run;
- a directory made by another configuration (or format) is refused (hash in ``dataset.json``);
  ``count`` is not part of the hash, so a dataset can be extended;
- a failing sample leaves no files and raises :exc:`SampleError` naming its index and seed;
  :func:`render_from_manifest` reproduces it alone.

One module on purpose: the run, its resume and its manifests share the on-disk layout and its
invariants (the folder rename is the completion marker), which are easier to keep in one place.
"""

from __future__ import annotations

import dataclasses
import fcntl
import json
import os
import re
import shutil
import tempfile
import time
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from matcher.io import atomic_write_bytes
from synth._json import read_json_object
from stereoforge.errors import DatasetError, ParameterError, StereoforgeError
from synth.dataset.config import DatasetConfig, config_from_dict, load_config
from synth.dataset.engine import ENGINES, run_tasks
from synth.dataset.integrity import completion_record, sample_problems
from synth.dataset.layout import (LAYOUT_VERSION, check_layout, record_path, sample_dir,
                                  sample_parent, write_scene_list)
from synth.dataset.manifest import MODIFIED_FIX, manifest_bytes, read_manifest
from synth.dataset.ray_driver import ray_connection
from synth.dataset.shards import ShardWriter, check_disp_encoding, check_shard_option
from synth.dataset.storage import FsPath, commit_sample, dataset_path, is_local, remove_tree, write_bytes
from synth.export import staged_output_dir, write_pair
from synth.formats import DATASET_FORMATS, KITTI_ROOT
from synth.photometric import apply_photometric
from synth.progress import progress as progress_bar
from synth.dataset.sampling import (
    STREAM_EXPOSURE_NOISE,
    STREAM_LIGHTING_NOISE,
    draw_sample,
    effective_frequency_px,
    sample_seed,
    stream,
)
from synth.texture_control import CANNY_SETTINGS, edge_density, match_edge_density

__all__ = ["DatasetError", "SampleError", "DatasetRun", "SampleTask", "produce_sample", "run_dataset",
           "render_from_manifest", "read_manifest"]

#: Version of the sample bytes: 2 since the photometric noise is drawn by quantile lookup
#: (``synth.photometric.gaussian_noise``); a dataset of another version is not resumed.
_FORMAT_VERSION = 2
_TMP_DIR = re.compile(r"^\.\d{6}\.tmp-\d+$")
_PHOTOMETRIC_STREAM = 3
_TEXTURELESS_STREAM = 5  # the order in which objects are made textureless
_HEADER_KEYS = {"config": dict, "format": str}


class SampleError(StereoforgeError, RuntimeError):
    """Rendering or writing one sample failed; ``index`` and ``seed`` reproduce it."""

    def __init__(self, index: int, seed: int, cause: str) -> None:
        super().__init__(f"sample {index} (seed {seed}) failed: {cause}; reproduce it alone with "
                         f"render_from_manifest(dataset_dir, {index}, out=...) or "
                         f"`stereoforge render --from-manifest DATASET_DIR {index} --out DIR`")
        self.index, self.seed, self.cause = index, seed, cause

    def __reduce__(self) -> tuple:  # picklable across processes
        return (SampleError, (self.index, self.seed, self.cause))


@dataclass(frozen=True)
class DatasetRun:
    """Summary of :func:`run_dataset`.

    Attributes
    ----------
    out : Path or synth.dataset.storage.FsPath
        The dataset's folder, or its location on an fsspec filesystem.
    count : int
        Samples the dataset holds (``0 .. count - 1``).
    rendered, skipped : int
        Samples rendered by this run, and found complete.
    seconds : float
        Wall time of the run.
    """

    out: Path | FsPath
    count: int
    rendered: int
    skipped: int
    seconds: float


def _textureless(scene: Any, config: DatasetConfig, draw: Any, renderer: Any
                 ) -> tuple[Any, float]:
    """The scene with objects made constant toward ``textureless_area`` (stream 5 orders them),
    and its measured textureless fraction (:mod:`synth.textureless`)."""
    from synth.textureless import match_textureless, object_coverage

    rig = config.rig
    coverage = object_coverage(scene, lambda s: renderer.render_view(s, rig, eye="left").color)
    return match_textureless(scene, float(draw.params["scene.textureless_area"]), coverage,
                             rig.width * rig.height, stream(draw.seed, _TEXTURELESS_STREAM))


def _r(value: float | None) -> float | None:
    return None if value is None else round(float(value), 6)


def _json_bytes(obj: Any) -> bytes:
    return (json.dumps(obj, indent=2, sort_keys=True) + "\n").encode()


# --------------------------------------------------------------------------- one sample
def render_draw(config: DatasetConfig, draw: Any, scene: Any, renderer: Any) -> Any:
    """The exact pair of a drawn sample: ``scene`` (the draw's, possibly changed after drawing)
    through the config's rig, with the draw's ``im1E`` exposure and ``im1L`` relighting when it
    asks for them. The one place a dataset sample (and a validate pair) is rendered."""
    from synth.pair import render_pair

    lighting = None
    if draw.relight is not None:
        lighting = dataclasses.replace(scene, light=draw.relight[0], lamps=draw.relight[1])
    return render_pair(scene, config.rig, renderer=renderer, exposure=draw.exposure,
                       lighting=lighting)


def produce_sample(config: DatasetConfig, index: int, renderer: Any, dest: Path, fmt: str, *,
             timings: dict[str, float] | None = None) -> dict:
    """Render sample ``index`` and write all its files into ``dest``; return its record.

    ``timings``, if given, accumulates the seconds spent per stage (draw, search, render,
    stats, photometric, write): wall time under ``stage`` and CPU time of the process (all
    threads, e.g. llvmpipe's) under ``stage + "_cpu"``.
    """
    clock = [time.perf_counter(), time.process_time()]

    def lap(stage: str) -> None:
        now = [time.perf_counter(), time.process_time()]
        if timings is not None:
            timings[stage] = timings.get(stage, 0.0) + now[0] - clock[0]
            timings[f"{stage}_cpu"] = timings.get(f"{stage}_cpu", 0.0) + now[1] - clock[1]
        clock[:] = now

    draw = draw_sample(config, index)
    scene, search = draw.scene, None
    lap("draw")
    if draw.edge_density is not None:
        search = match_edge_density(scene, config.rig, draw.edge_density, renderer=renderer)
        scene = search.scene
    textureless = None
    if "scene.textureless_area" in draw.params:
        scene, textureless = _textureless(scene, config, draw, renderer)
    lap("search")
    pair = render_draw(config, draw, scene, renderer)
    lap("render")
    out = apply_photometric(pair.left, pair.right, draw.photometric,
                            rng=stream(draw.seed, _PHOTOMETRIC_STREAM))
    variants = {}  # the right-view variants under the same sensor model, their own noise
    for name, noise in (("right_exposure", STREAM_EXPOSURE_NOISE),
                        ("right_lighting", STREAM_LIGHTING_NOISE)):
        if getattr(pair, name) is not None:
            variants[name] = apply_photometric(pair.left, getattr(pair, name), draw.photometric,
                                               rng=stream(draw.seed, noise)).right
    lap("photometric")
    if search is not None and np.array_equal(search.left, pair.left):
        rho = search.edge_density  # the search measured this very image: skip a second Canny
    else:
        rho = edge_density(pair.left)
    degraded = dataclasses.replace(pair, left=out.left, right=out.right, **variants)
    finite = np.isfinite(pair.disp_left)
    has_finite = bool(finite.any())
    mask_size = pair.mask_left.size
    stats = {
        "edge_density": _r(rho),
        "edge_search_probes": None if search is None else search.probes,
        "edge_search_converged": None if search is None else search.converged,
        "texture_frequency_px": _r(effective_frequency_px(scene, fx=config.rig.fx)),
        "disp_min": _r(np.min(pair.disp_left, where=finite, initial=np.inf)) if has_finite
        else None,
        "disp_max": _r(np.max(pair.disp_left, where=finite, initial=-np.inf)) if has_finite
        else None,
        # = np.mean(mask == code): the same float (an exact count over the size), 6x faster
        "occluded_fraction": _r(np.count_nonzero(pair.mask_left == 128) / mask_size),
        "invalid_fraction": _r(np.count_nonzero(pair.mask_left == 0) / mask_size),
    }
    if textureless is not None:  # only then: other datasets keep their manifests' bytes
        stats["textureless_fraction"] = _r(textureless)
    lap("stats")
    record = {"index": index, "seed": draw.seed, "dir": f"{index:06d}",
              "params": dict(draw.params), "stats": stats}
    dest.mkdir(parents=True, exist_ok=True)
    write_pair(degraded, dest, scene=scene, seed=draw.seed, index=index,
               fmt="middlebury" if fmt == "webdataset" else fmt,  # shards: packed from these
               preview=config.preview, fsync=False)
    if config.ground_truth:  # optional: rendered by an extra GT pass (synth.ground_truth)
        from synth.ground_truth import render_ground_truth, write_ground_truth

        write_ground_truth(dest, render_ground_truth(pair, scene, config.ground_truth,
                                                     renderer=renderer), fsync=False)
    atomic_write_bytes(dest / "sample.json", _json_bytes(record), fsync=False)
    lap("write")
    return record


def _commit(tmp: Path, out: Path, index: int, fmt: str) -> None:
    """Move a finished sample into place; the final rename is the completion marker."""
    if fmt == "kitti":
        shared = tmp / KITTI_ROOT
        for sub in sorted(shared.iterdir()):
            (out / KITTI_ROOT / sub.name).mkdir(parents=True, exist_ok=True)
            for f in sorted(sub.iterdir()):
                os.replace(f, out / KITTI_ROOT / sub.name / f.name)
            sub.rmdir()
        shared.rmdir()
    final = sample_dir(out, fmt, index)
    final.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.rename(tmp, final)
    except OSError:
        if not record_path(out, index).is_file():
            raise
        shutil.rmtree(tmp, ignore_errors=True)  # finished meanwhile by another process: same bytes
    # No fsync of `out`: the files are not fsynced either (see docs/datasets.md), so making the
    # rename durable would buy nothing after a power loss, and it costs ~3 ms per sample.


def _dataset_files(tmp: Path, index: int, fmt: str) -> list[tuple[str, Path]]:
    """The files of a sample's temporary folder, as (path in the dataset, file) pairs."""
    folder = sample_dir(Path(), fmt, index).as_posix()
    files = []
    for path in sorted(p for p in tmp.rglob("*") if p.is_file()):
        rel = path.relative_to(tmp)
        in_dataset = rel.as_posix() if fmt == "kitti" and rel.parts[0] == KITTI_ROOT \
            else f"{folder}/{rel.as_posix()}"
        files.append((in_dataset, path))
    return files


def _record_name(index: int) -> str:
    """The completion record's path in the dataset (``records/NNNNNN.json``)."""
    return record_path(Path(), index).as_posix()


def _write_record(out: Path | FsPath, index: int, record: bytes) -> None:
    """Write the completion record last, once the sample's files are in place."""
    path = record_path(out, index)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_bytes(path, record)


def _returned_files(tmp: Path, index: int, fmt: str) -> dict[str, bytes]:
    """A rendered sample's files as a worker returns them (path in the dataset -> bytes), its
    completion record among them."""
    listed = _dataset_files(tmp, index, fmt)
    files = {name: path.read_bytes() for name, path in listed}
    files[_record_name(index)] = completion_record(index, listed)
    return files


def commit_returned(tmp: Path, out: Path | FsPath, index: int, fmt: str) -> None:
    """What a sample costs the driver on the Ray engine or a URL output: the files of ``tmp``
    (a folder :func:`produce_sample` wrote) returned as bytes and committed into ``out``
    (``stereoforge bench dataset`` times it)."""
    files = _returned_files(tmp, index, fmt)
    commit_sample(out, index, files, folder=sample_dir(Path(), fmt, index).as_posix(),
                  record=_record_name(index),
                  commit_local=lambda t, root: _commit(t, root, index, fmt))


class SampleTask:
    """Picklable per-sample job (see :mod:`synth.dataset.engine`).

    With ``out`` a local folder the worker writes and commits the sample itself and returns its
    record. With ``out=None`` it writes nothing where the driver writes: it renders into a
    temporary folder of its own machine and returns ``(record, files)``, ``files`` mapping each
    path in the dataset (the completion record included) to its bytes, for the driver to
    :func:`~synth.dataset.storage.commit_sample` (Ray workers, URL outputs: no shared
    filesystem assumed).
    """

    preload = ("synth.pair",)  # imported once by the engine's fork server for every worker

    def __init__(self, config: DatasetConfig, out: Path | None, fmt: str, backend: str) -> None:
        self.config_dict = config.to_dict()
        self.source = config.source
        self.out, self.fmt, self.backend = None if out is None else Path(out), fmt, backend
        self.width, self.height = config.rig.width, config.rig.height
        self._config: DatasetConfig | None = config

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_config": None}

    @property
    def config(self) -> DatasetConfig:
        if self._config is None:
            self._config = config_from_dict(self.config_dict, source=self.source)
        return self._config

    def __call__(self, index: int, renderer: Any) -> dict | tuple[dict, dict[str, bytes]]:
        tmp = (Path(tempfile.mkdtemp(prefix=f"stereoforge-{index:06d}-")) if self.out is None
               else self.out / f".{index:06d}.tmp-{os.getpid()}")
        try:
            shutil.rmtree(tmp, ignore_errors=True)
            record = produce_sample(self.config, index, renderer, tmp, self.fmt)
            if self.out is None:
                files = _returned_files(tmp, index, self.fmt)
                shutil.rmtree(tmp, ignore_errors=True)
                return record, files
            done = completion_record(index, _dataset_files(tmp, index, self.fmt))
            _commit(tmp, self.out, index, self.fmt)
            _write_record(self.out, index, done)
            return record
        except BaseException as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            if isinstance(exc, Exception) and not isinstance(exc, SampleError):
                seed = sample_seed(self.config.seed, index)
                raise SampleError(index, seed, f"{type(exc).__name__}: {exc}") from exc
            raise


# --------------------------------------------------------------------------- manifest
def _write_manifest(out: Path) -> list[dict]:
    records = read_manifest(out)
    jsonl, table = manifest_bytes(records)
    write_bytes(out / "manifest.jsonl", jsonl)
    write_bytes(out / "manifest.csv", table)
    return records


# --------------------------------------------------------------------------- dataset.json / lock
def _dataset_header(config: DatasetConfig, fmt: str) -> dict:
    return {"format_version": _FORMAT_VERSION, "name": config.name,
            "config": config.to_dict(with_count=False), "config_hash": config.hash(),
            "format": fmt, "layout": LAYOUT_VERSION, "canny": CANNY_SETTINGS,
            "seeding": "sample_seed = SeedSequence(seed, spawn_key=(index,)).generate_state(1, "
                       "uint64)[0] >> 1"}


def _open_dataset(out: Path, config: DatasetConfig, fmt: str, shard_size: int | None,
                  disp_encoding: str | None) -> None:
    header = _dataset_header(config, fmt)
    if shard_size is not None:
        header["shard_size"] = shard_size
    if disp_encoding is not None:  # absent by default: dataset.json as before
        header["disp_encoding"] = disp_encoding
    path = out / "dataset.json"
    if path.is_file():
        old = read_json_object(path, what="dataset header", fix=MODIFIED_FIX)
        if old.get("shard_size") != shard_size:
            raise DatasetError(f"{out} holds shards of {old.get('shard_size')} bytes, not "
                               f"{shard_size}; rerun with --shard-size {old.get('shard_size')}")
        if old.get("disp_encoding") != disp_encoding:
            raise DatasetError(f"{out} holds shards with float maps encoded as "
                               f"{old.get('disp_encoding') or 'pfm'}, not {disp_encoding or 'pfm'}"
                               f"; rerun with --disp-encoding {old.get('disp_encoding') or 'pfm'}")
        if old.get("config_hash") != header["config_hash"] or old.get("format") != fmt:
            raise DatasetError(
                f"{out} holds dataset {old.get('name')!r} (format {old.get('format')!r}, config "
                f"hash {str(old.get('config_hash'))[:12]}) made by another configuration than "
                f"{config.source} (format {fmt!r}, hash {header['config_hash'][:12]}); choose "
                "another output directory, or delete this one to start over")
        if old.get("format_version") != _FORMAT_VERSION:
            raise DatasetError(
                f"{out} holds dataset {old.get('name')!r} of sample format version "
                f"{old.get('format_version')!r}, written by another stereoforge version; this "
                f"one writes version {_FORMAT_VERSION} (other bytes for the same seeds), so the "
                "dataset cannot be extended here: finish it with the version that started it, "
                "or choose a new output directory")
        check_layout(out)
        return
    others = sorted(p.name for p in out.iterdir() if p.name != ".lock")
    if others:
        raise DatasetError(f"{out} is not empty ({', '.join(others[:5])}"
                           f"{', ...' if len(others) > 5 else ''}) and holds no dataset.json; "
                           "choose an empty or new directory")
    write_bytes(path, _json_bytes(header))


def _lock(out: Path | FsPath) -> int | None:
    if not is_local(out):
        return None  # object stores have no lock: one run per output URL at a time
    fd = os.open(out / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise DatasetError(f"another run is writing {out} (it holds {out / '.lock'}); wait for "
                           "it to finish or stop it") from None
    return fd


# --------------------------------------------------------------------------- public API
def run_dataset(
    config: str | Path | DatasetConfig,
    out: str | Path,
    *,
    count: int | None = None,
    workers: int = 1,
    engine: str = "local",
    address: str | None = None,
    fmt: str = "middlebury",
    progress: bool = True,
    backend: str = "auto",
    shard_size: int | None = None,
    disp_encoding: str | None = None,
) -> DatasetRun:
    """Render (or finish) the dataset of ``config`` into ``out``.

    Parameters
    ----------
    config : str, Path or DatasetConfig
        A TOML file, the name of a shipped example (``planes``, ``texture-sweep``, ``flying``)
        or a parsed configuration.
    out : str or Path
        Dataset directory: new, empty, or holding a (partial) dataset of the same config and
        format, which is completed. A local path, a ``file://`` URL or any fsspec URL
        (``memory://``, ``s3://bucket/prefix`` with s3fs, ``gs://`` with gcsfs: needs
        ``pip install 'stereoforge[storage]'``; see :mod:`synth.dataset.storage`).
    count : int, optional
        Samples ``0 .. count - 1`` (default: the config's ``count``).
    workers : int
        Processes (``engine="local"``) or Ray actors (``engine="ray"``), one renderer each.
    engine : {"local", "ray"}
    address : str, optional
        Ray cluster address; default a local Ray with ``num_cpus=workers``. The cluster is
        joined before ``out`` is made or opened: an address that does not answer, or fails
        Ray's handshake, raises :class:`~stereoforge.errors.BackendError` and leaves no folder
        (and an existing dataset as it was).
    fmt : {"middlebury", "kitti", "webdataset"}
        ``webdataset``: tar shards (:mod:`synth.dataset.shards`).
    progress : bool
        Show a progress bar (stderr).
    backend : {"auto", "egl", "osmesa"}
        GL backend of every worker's renderer.
    disp_encoding : {"pfm", "pfm.gz"}, optional
        How ``fmt="webdataset"`` stores the float maps (default ``pfm``; ``pfm.gz``: gzip,
        lossless); refused with other formats.
    shard_size : int, optional
        Bytes per shard of ``fmt="webdataset"`` (default about 1 GB); refused with other formats.

    Returns
    -------
    DatasetRun

    Raises
    ------
    DatasetError
        ``out`` holds another dataset, other files, or is being written by another run.
    BackendError
        ``engine="ray"``: the cluster cannot be reached or joined, or no worker could start
        (:data:`synth.dataset.ray_driver.RAY_STALL_TIMEOUT_S`); the samples finished stay.
    SampleError
        A sample failed (its index and seed are in the message); the samples completed before
        stay, and the manifest lists them.
    synth.dataset.config.ConfigError
        The configuration is invalid (file, line, allowed values).

    Examples
    --------
    >>> import tempfile
    >>> tmp = tempfile.mkdtemp()
    >>> run = run_dataset("planes", out=f"{tmp}/planes", count=2, progress=False)
    >>> run.rendered, sorted(p.name for p in (run.out / "MiddEval3" / "trainingF").iterdir())
    (2, ['000000', '000001'])
    """
    out = dataset_path(out)  # a URL whose filesystem is not installed fails here, before any work
    cfg = load_config(config)
    count = cfg.count if count is None else count
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= 999_999:
        raise ValueError(f"count must be an int in [1, 999999], got {count!r}")
    if fmt not in DATASET_FORMATS:
        raise ValueError(f"fmt must be one of {', '.join(DATASET_FORMATS)}, got {fmt!r}")
    shard_size = check_shard_option(fmt, shard_size)
    disp_encoding = check_disp_encoding(fmt, disp_encoding)
    if cfg.rig.errors is not None and fmt == "kitti":
        raise DatasetError(f"{cfg.source}: the [rig] camera errors give each sample a flow0.flo, "
                           f"which the KITTI layout cannot hold; use --format middlebury "
                           "(or webdataset)")
    if cfg.ground_truth and fmt == "kitti":
        raise ParameterError(f"{cfg.source}: ground_truth = {list(cfg.ground_truth)} has no place "
                             "in the KITTI 2015 layout; use fmt='middlebury' or 'webdataset', or "
                             "drop ground_truth")
    if shard_size is not None and not is_local(out):
        raise ParameterError(f"{out}: --format webdataset packs its shards in a local folder; "
                             "write them to a path (and copy the shards to object storage)")
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an int >= 1, got {workers!r}")
    t0 = time.perf_counter()
    if out.exists() and not out.is_dir():
        raise DatasetError(f"{out} exists and is not a directory; choose another output")
    with ExitStack() as held:
        if engine == "ray" and address is not None:
            # joined before the folder is made: an address that does not answer, or fails Ray's
            # handshake, leaves no folder (and an existing dataset untouched)
            held.enter_context(ray_connection(address, workers=workers))
        out.mkdir(parents=True, exist_ok=True)
        lock = _lock(out)
        if lock is not None:
            held.callback(os.close, lock)
        _open_dataset(out, cfg, fmt, shard_size, disp_encoding)
        for stale in out.iterdir():
            if _TMP_DIR.match(stale.name):
                remove_tree(stale)
        # a sample is done when its completion record exists and its files have the recorded
        # sizes (checksums: verify_dataset, `stereoforge dataset --verify`); else render again
        packer = None if shard_size is None else ShardWriter(
            out, sample_parent(out, fmt), shard_size, count,
            complete=lambda i: not sample_problems(out, fmt, i),
            forget=lambda i: record_path(out, i).unlink(missing_ok=True),
            disp_encoding=disp_encoding)
        todo = packer.todo(count) if packer else [i for i in range(count)
                                                 if sample_problems(out, fmt, i)]
        for i in todo:
            remove_tree(record_path(out, i))
            remove_tree(sample_dir(out, fmt, i))
        # Ray workers and URL outputs: the workers return the bytes, this process writes them
        returns_bytes = engine == "ray" or not is_local(out)
        task = SampleTask(cfg, None if returns_bytes else out, fmt, backend)
        bar = progress_bar(total=len(todo), desc=f"dataset {cfg.name}", unit="pair",
                           enabled=progress)
        try:
            for index, result in run_tasks(task, todo, workers=workers, engine=engine,
                                           address=address):
                if returns_bytes:
                    commit_sample(out, index, result[1],
                                  folder=sample_dir(Path(), fmt, index).as_posix(),
                                  record=_record_name(index),
                                  commit_local=lambda t, root, i=index: _commit(t, root, i, fmt))
                bar.update()
                if packer:
                    packer.advance(count)
            if packer:
                packer.advance(count)
                packer.finish()
        except BaseException:
            if packer:
                packer.abort()
            raise
        finally:
            bar.close()
            write_scene_list(out, fmt, [r["dir"] for r in _write_manifest(out)])
    return DatasetRun(out=out, count=count, rendered=len(todo), skipped=count - len(todo),
                      seconds=time.perf_counter() - t0)


def render_from_manifest(dataset_dir: str | Path, index: int, *, out: str | Path,
                         overwrite: bool = False,
                         backend: str = "auto") -> list[Path]:
    """Re-render sample ``index`` of a dataset alone, into ``out``, with the dataset's bytes.

    The configuration comes from ``dataset_dir/dataset.json``; the sample need not be complete
    (this is how a failed sample is reproduced). ``out`` receives the sample's files as in the
    dataset (Middlebury: ``im0.png ...``; KITTI: ``training/image_2/NNNNNN_10.png ...``) plus
    ``scene.json`` and ``sample.json``. A non-empty ``out`` is refused unless ``overwrite``.
    The files are written into a temporary folder beside ``out`` and renamed into place when all
    are written (:func:`synth.export.staged_output_dir`): a failure (disk full, a failed render)
    leaves ``out`` as it was, and a rerun into it works.

    Returns
    -------
    list of Path
        The files written, sorted.

    Raises
    ------
    SampleError
        If the sample fails (message with index and seed).

    Examples
    --------
    >>> import tempfile
    >>> tmp = tempfile.mkdtemp()
    >>> _ = run_dataset("planes", out=f"{tmp}/planes", count=2, progress=False)
    >>> files = render_from_manifest(f"{tmp}/planes", 1, out=f"{tmp}/planes-1")
    >>> sorted(f.name for f in files)[:3]
    ['calib.txt', 'disp0GT.pfm', 'disp1GT.pfm']
    >>> from pathlib import Path
    >>> Path(tmp, "planes-1", "im0.png").read_bytes() == Path(tmp, "planes", "MiddEval3", "trainingF", "000001", "im0.png").read_bytes()
    True
    """
    from synth.render.renderer import Renderer

    root = Path(dataset_dir)
    path = root / "dataset.json"
    if not path.is_file():
        raise DatasetError(f"{root} has no dataset.json; pass a directory made by run_dataset")
    header = read_json_object(path, what="dataset header", keys=_HEADER_KEYS, fix=MODIFIED_FIX)
    cfg = config_from_dict(header["config"], source=str(path))
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index <= 999_999:
        raise ParameterError(f"index must be an int in [0, 999999], got {index!r}")
    check_layout(root)
    record = sample_dir(root, header["format"], index) / "sample.json"
    seed = sample_seed(cfg.seed, index)
    if record.is_file() and read_json_object(record, what="sample record", keys={"seed": int},
                                             fix=MODIFIED_FIX)["seed"] != seed:
        raise DatasetError(f"{record} has another seed than sample {index} of {path}; the "
                           "dataset directory was modified")
    dest = Path(out)
    with staged_output_dir(dest, overwrite=overwrite) as stage:
        try:
            with Renderer(cfg.rig.width, cfg.rig.height, backend=backend) as renderer:
                produce_sample(cfg, index, renderer, stage, header["format"])
        except OSError:
            raise  # disk full, read-only: an environment error naming the file, not the sample
        except Exception as exc:
            raise SampleError(index, seed, f"{type(exc).__name__}: {exc}") from exc
        names = sorted(p.relative_to(stage) for p in stage.rglob("*") if p.is_file())
    return [dest / name for name in names]
