"""Datasets at scale: many labelled pairs from one configuration, deterministic and resumable.

Layout of a dataset directory ``out/``::

    dataset.json        configuration (canonical), its hash, format, Canny settings
    manifest.jsonl      one JSON record per complete sample, sorted by index
    manifest.csv        the same records, flattened (``params.*``, ``stats.*`` columns)
    MiddEval3/trainingF/000000/   sample 0: im0.png im1.png disp0GT.pfm ... calib.txt
                        scene.json sample.json [preview.png]          (fmt="middlebury")
    MiddEval3/official_train.txt  the complete samples' names (RAFT-Stereo's Middlebury loader)
    2014/000000/        sample 0 as a 2014 scene archive: disp0.pfm ... (fmt="middlebury2014")
    training/samples/000000/      scene.json sample.json; the images go to  (fmt="kitti")
    training/image_2/ image_3/ disp_occ_0/ disp_noc_0/ obj_map/   000000_10.png ...
    training/calib_cam_to_cam/                                    000000.txt
    .lock               locked by the runs writing the directory (synth.dataset.parts)

Guarantees (see ``docs/datasets.md``):

- sample ``i`` depends only on the configuration and ``i`` (its seed is
  :func:`synth.dataset.config.sampling.sample_seed`), so its files are byte-identical whatever
  the number of workers, the engine or the order;
- a sample is written into ``.NNNNNN.tmp-<pid>/`` and renamed to its folder (above; see
  :mod:`synth.dataset.storage.layout`); its completion record ``records/NNNNNN.json`` (every
  file with size and SHA-256, :mod:`synth.dataset.storage.integrity`) is written last.
  A run killed at any point and restarted skips the samples whose record exists and whose files
  have the recorded sizes, renders the others again (an emptied folder, a truncated file) and
  ends with the same bytes as an uninterrupted run;
- a directory made by another configuration (or format) is refused (hash in ``dataset.json``);
  ``count`` is not part of the hash, so a dataset can be extended;
- several runs over disjoint ``indices`` (one driver each) may write one dataset at once, and a
  whole run then writes the manifests (:mod:`synth.dataset.parts`);
- a failing sample leaves no files and raises :exc:`SampleError` naming its index and seed;
  :func:`render_from_manifest` reproduces it alone.

The run, its resume and its manifests live here; one sample's production and the per-sample task
are :mod:`synth.dataset.sample`, the commit of a rendered sample (rename, completion record,
returned bytes) :mod:`synth.dataset.storage.commit`.
"""

from __future__ import annotations

import re
import time
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

from synth._util.json_records import json_bytes, read_json_object
from stereoforge.errors import DatasetError, ParameterError
from synth.dataset.config.rig_draws import config_rigs
from synth.dataset.storage.commit import commit_files, commit_returned
from synth.dataset.config.parse import DatasetConfig, config_from_dict, load_config
from synth.dataset.engine.tasks import check_engine, run_tasks
from synth.dataset.storage.integrity import sample_problems
from synth.dataset.storage.layout import (LAYOUT_VERSION, check_layout, record_path, sample_dir,
                                          sample_parent, write_scene_list)
from synth.dataset.storage.manifest import MODIFIED_FIX, manifest_bytes, read_manifest
from synth.dataset.parts import check_indices, is_part, lock_run
from synth.dataset.engine.ray_driver import ray_connection
from synth.dataset.sample import SampleError, SampleTask, produce_sample, render_draw
from synth.dataset.config.sampling import sample_seed
from synth.dataset.storage.shards import ShardWriter, check_disp_encoding, check_shard_option
from synth.dataset.storage.fs import FsPath, dataset_path, is_local, remove_tree, write_bytes
from synth.write.export import staged_output_dir
from synth.formats import DATASET_FORMATS, DEFAULT_FORMAT, get_layout
from synth._util.progress import progress as progress_bar
from synth.appearance.texture_control import CANNY_SETTINGS

# SampleError, SampleTask, produce_sample, render_draw (synth.dataset.sample) and the commit
# functions (synth.dataset.storage.commit) are re-exported: the run's public surface stays in one
# place
__all__ = ["DatasetError", "SampleError", "DatasetRun", "SampleTask", "produce_sample", "run_dataset",
           "render_from_manifest", "read_manifest", "render_draw", "commit_files",
           "commit_returned"]

#: Version of the sample bytes: 2 since the photometric noise is drawn by quantile lookup
#: (``synth.appearance.photometric.gaussian_noise``); a dataset of another version is not resumed.
_FORMAT_VERSION = 2
_TMP_DIR = re.compile(r"^\.\d{6}\.tmp-\d+$")
_HEADER_KEYS = {"config": dict, "format": str}


@dataclass(frozen=True)
class DatasetRun:
    """Summary of :func:`run_dataset`.

    Attributes
    ----------
    out : Path or synth.dataset.storage.fs.FsPath
        The dataset's folder, or its location on an fsspec filesystem.
    count : int
        Samples the dataset holds (``0 .. count - 1``).
    rendered, skipped : int
        Samples of ``indices`` rendered by this run, and found complete.
    seconds : float
        Wall time of the run.
    indices : range
        The samples this run covered (``range(count)`` unless it was a part).
    damaged : tuple of (int, tuple of str)
        The rendered samples that were there but damaged or incomplete (a truncated or missing
        file, an emptied folder, no or an unreadable completion record), in index order, each
        with what was wrong: one line a file
        (:func:`synth.dataset.storage.integrity.sample_problems`), or one for an emptied folder.
        Samples never rendered before are not in it.
    notes : tuple of str
        What a dataset of this count lacks in its layout, to tell the user
        (:meth:`synth.formats.base.Layout.count_note`: a SceneFlow dataset of fewer than 22
        samples has an empty TEST split).
    """

    out: Path | FsPath
    count: int
    rendered: int
    skipped: int
    seconds: float
    indices: range = range(0)
    damaged: tuple[tuple[int, tuple[str, ...]], ...] = ()
    notes: tuple[str, ...] = ()


def _damage(out: Path | FsPath, fmt: str, index: int) -> tuple[str, ...]:
    """What is wrong with sample ``index`` if some of it is there (its folder or its record);
    empty for a sample never rendered."""
    folder, record = sample_dir(out, fmt, index), record_path(out, index)
    if not folder.exists() and not record.exists():
        return ()
    own = f"{index:06d}: "  # "000008: no completion record ...": the index is said once
    problems = [p.removeprefix(own) for p in sample_problems(out, fmt, index)]
    where = sample_dir(Path(), fmt, index).as_posix()
    if problems == ["missing"]:  # the record is there, the folder is not
        return (f"{where}: missing (its completion record {record.parent.name}/{record.name} "
                "is there)",)
    if folder.is_dir() and not any(folder.iterdir()):  # one line, not one per file
        inside = [p for p in problems if p.startswith(f"{where}/")]
        return (f"{where}: empty (the {len(inside)} files its record lists there are missing)",
                *(p for p in problems if not p.startswith(f"{where}/")))
    return tuple(problems)


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
    if not path.is_file():
        others = sorted(p.name for p in out.iterdir() if p.name != ".lock")
        if not others:  # drivers creating it at once (object stores) write the same bytes
            write_bytes(path, json_bytes(header))
        elif not path.is_file():  # (unless another driver of this dataset just wrote it)
            raise DatasetError(f"{out} is not empty ({', '.join(others[:5])}"
                               f"{', ...' if len(others) > 5 else ''}) and holds no dataset.json; "
                               "choose an empty or new directory")
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


# --------------------------------------------------------------------------- public API
def run_dataset(
    config: str | Path | DatasetConfig,
    out: str | Path,
    *,
    count: int | None = None,
    workers: int = 1,
    engine: str = "local",
    address: str | None = None,
    fmt: str = DEFAULT_FORMAT,
    progress: bool = True,
    backend: str = "auto",
    shard_size: int | None = None,
    disp_encoding: str | None = None,
    indices: range | None = None,
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
        ``pip install 'stereoforge[storage]'``; see :mod:`synth.dataset.storage.fs`).
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
    fmt : str
        One of :data:`synth.formats.DATASET_FORMATS` (:mod:`synth.formats`): ``middlebury``:
        MiddEval3 scene folders, ``middlebury2014``: the 2014 scene archives'
        (``2014/NNNNNN/disp0.pfm``), ``kitti``: KITTI 2015 frames; the training layouts
        ``sceneflow`` (FlyingThings3D's tree), ``crestereo``, ``fsd``; ``webdataset``: tar shards
        (:mod:`synth.dataset.storage.shards`). What the layout cannot hold (a rig's flow, optional
        ground truth, disparities beyond its range or below its quantum) is refused first.
    progress : bool
        Show a progress bar (stderr).
    backend : {"auto", "egl", "osmesa"}
        GL backend of every worker's renderer.
    disp_encoding : {"pfm", "pfm.gz"}, optional
        How ``fmt="webdataset"`` stores the float maps (default ``pfm``; ``pfm.gz``: gzip,
        lossless); refused with other formats.
    shard_size : int, optional
        Bytes per shard of ``fmt="webdataset"`` (default about 1 GB); refused with other formats.
    indices : range, optional
        Only these samples (step 1, inside ``0 .. count - 1``; default all): one *part* of the
        dataset, which ``count`` still defines. Parts on disjoint ranges may write into one
        ``out`` at once (one driver each); a part writes no manifest: once all have ended, a run
        without ``indices`` writes it (and renders only what is missing). Refused with
        ``fmt="webdataset"``. See :mod:`synth.dataset.parts`.

    Returns
    -------
    DatasetRun

    Raises
    ------
    DatasetError
        ``out`` holds another dataset, other files, or another run is writing it (a whole run,
        or a part whose ``indices`` overlap).
    BackendError
        ``engine="ray"``: the cluster cannot be reached or joined, or no worker could start
        (:data:`synth.dataset.engine.ray_driver.RAY_STALL_TIMEOUT_S`); the samples finished stay.
    SampleError
        A sample failed (its index and seed are in the message); the samples completed before
        stay, and the manifest lists them.
    synth.dataset.config.parse.ConfigError
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
    indices = check_indices(indices, count, fmt=fmt)
    part = is_part(indices, count)
    shard_size = check_shard_option(fmt, shard_size)
    disp_encoding = check_disp_encoding(fmt, disp_encoding)
    layout = get_layout(fmt)  # what the layout cannot hold is refused before any work
    layout.check_config(flow=any(r.errors is not None for r in config_rigs(cfg)),
                        ground_truth=tuple(cfg.ground_truth or ()),
                        source=str(cfg.source), image_deflate=cfg.image_deflate)
    for rig in config_rigs(cfg):  # at the extremes of drawn rigs, of every part of a mix
        layout.check_rig(rig, source=str(cfg.source))
    if shard_size is not None and not is_local(out):
        raise ParameterError(f"{out}: --format webdataset packs its shards in a local folder; "
                             "write them to a path (and copy the shards to object storage)")
    check_engine(engine, workers=workers, address=address)  # before the folder is made
    t0 = time.perf_counter()
    if out.exists() and not out.is_dir():
        raise DatasetError(f"{out} exists and is not a directory; choose another output")
    with ExitStack() as held:
        if engine == "ray" and (address is not None or not out.exists()):
            # joined (or, for a new folder, a local Ray started) before the folder is made: an
            # address that does not answer, a failed handshake or a local Ray that cannot start
            # leaves no folder (and an existing dataset untouched; for one, a local Ray starts
            # only when there is work, in run_tasks)
            held.enter_context(ray_connection(address, workers=workers))
        out.mkdir(parents=True, exist_ok=True)
        lock = lock_run(out, indices, count)
        held.callback(lock.close)
        with lock.header():
            _open_dataset(out, cfg, fmt, shard_size, disp_encoding)
        for stale in out.iterdir():  # a part removes its own only: another's may be in use
            if _TMP_DIR.match(stale.name) and (not part or int(stale.name[1:7]) in indices):
                remove_tree(stale)
        # a sample is done when its completion record exists and its files have the recorded
        # sizes (checksums: verify_dataset, `stereoforge dataset --verify`); else render again
        packer = None if shard_size is None else ShardWriter(
            out, sample_parent(out, fmt), shard_size, count,
            complete=lambda i: not sample_problems(out, fmt, i),
            forget=lambda i: record_path(out, i).unlink(missing_ok=True),
            disp_encoding=disp_encoding)
        todo = packer.todo(count) if packer else [i for i in indices
                                                 if sample_problems(out, fmt, i)]
        damaged = tuple((i, found) for i in todo if (found := _damage(out, fmt, i)))
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
                    commit_files(out, index, result[1], fmt)
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
            if not part:  # a part leaves the manifests to a whole run (synth.dataset.parts)
                write_scene_list(out, fmt, [r["dir"] for r in _write_manifest(out)])
    note = layout.count_note(count)
    return DatasetRun(out=out, count=count, rendered=len(todo), skipped=len(indices) - len(todo),
                      seconds=time.perf_counter() - t0, indices=indices, damaged=damaged,
                      notes=() if note is None else (note,))


def render_from_manifest(dataset_dir: str | Path, index: int, *, out: str | Path,
                         overwrite: bool = False,
                         backend: str = "auto") -> list[Path]:
    """Re-render sample ``index`` of a dataset alone, into ``out``, with the dataset's bytes.

    The configuration comes from ``dataset_dir/dataset.json``; ``dataset_dir`` is a folder or
    an fsspec URL (``s3://bucket/prefix``, as :func:`run_dataset` takes), read in place. The
    sample need not be complete (this is how a failed sample is reproduced). ``out`` receives the sample's files as in the
    dataset (Middlebury: ``im0.png ...``; KITTI: ``training/image_2/NNNNNN_10.png ...``) plus
    ``scene.json`` and ``sample.json``. A non-empty ``out`` is refused unless ``overwrite``.
    The files are written into a temporary folder beside ``out`` and renamed into place when all
    are written (:func:`synth.write.export.staged_output_dir`): a failure (disk full, a failed
    render) leaves ``out`` as it was, and a rerun into it works.

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

    root = dataset_path(dataset_dir)  # a folder, or a URL (its filesystem package checked)
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
