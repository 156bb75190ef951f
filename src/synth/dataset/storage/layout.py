"""Where a dataset's sample folders live, so that real stereo tools read the directory as it is.

Layout 2 (this version)::

    out/
      dataset.json  manifest.jsonl  manifest.csv  .lock      stereoforge's own files
      records/000000.json         completion record of sample 0 (synth.dataset.storage.integrity)
      MiddEval3/                                              fmt="middlebury"
        official_train.txt        every complete sample's name, one a line
        trainingF/000000/         im0.png im1.png disp0GT.pfm ... scene.json sample.json
      2014/                                                   fmt="middlebury2014"
        000000/                   im0.png im1.png im1E.png im1L.png disp0.pfm ... sample.json
      training/                                               fmt="kitti"
        image_2/ image_3/ disp_occ_0/ disp_noc_0/ obj_map/ calib_cam_to_cam/
        samples/000000/           scene.json sample.json
      SceneFlow/ CREStereo/ FSD/                              fmt="sceneflow", "crestereo", "fsd"
      samples/000000/             calib.txt scene.json sample.json (of those three)

Where each format's files go is its layout's (:mod:`synth.formats`: ``sample_parent``,
``tools_root``); this module names the folders of a dataset through it.
``MiddEval3/trainingF/<scene>/`` and ``MiddEval3/official_train.txt`` are where RAFT-Stereo's
``Middlebury(root, split="F")`` looks, and ``trainingF/`` is what MiddEval3's ``runeval F`` walks
when the SDK is unpacked into ``MiddEval3/``; ``2014/<scene>/`` is where its ``split="2014"``
takes every entry for a scene folder of the 2014 archives (so ``2014/`` holds nothing else);
``training/image_2`` is RAFT-Stereo's and the KITTI devkit's root. Nothing of stereoforge's own
dataset metadata (header, manifests, lock, completion records) sits in those folders; a sample
folder holds its own ``scene.json`` and ``sample.json`` beside the files the tools read, which
they ignore. Layout 1 (stereoforge before this version) put the sample folders ``000000/`` at the
root, beside ``dataset.json``, with the completion record ``000000/files.json`` inside, where the
tools took them (and ``dataset.json``) for scenes: :func:`upgrade_dataset` converts it.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterator
from pathlib import Path

from matcher.io import atomic_write_bytes
from stereoforge.errors import DatasetError
from synth._util.json_records import json_bytes, read_json_object
from synth.dataset.storage.fs import FsPath, dataset_path, write_bytes
from synth.formats import DATASET_FORMATS, get_layout

__all__ = ["LAYOUT_VERSION", "RECORDS", "SAMPLE_DIR", "METADATA", "sample_parent", "sample_dir",
           "sample_dirs", "tools_root", "record_path", "dataset_format", "check_layout",
           "write_scene_list", "upgrade_dataset"]

#: Version of the directory layout, ``layout`` in ``dataset.json`` (absent: layout 1).
LAYOUT_VERSION = 2
#: Folder of the completion records, ``records/NNNNNN.json``, at the dataset's root.
RECORDS = "records"
#: Name of a sample folder: its index on six digits.
SAMPLE_DIR = re.compile(r"^\d{6}$")
#: stereoforge's own files at the dataset's root (beside ``RECORDS`` and the tools' folders).
METADATA = ("dataset.json", "manifest.jsonl", "manifest.csv", ".lock", "shards.json")
_SAMPLE_NAME = SAMPLE_DIR
_LEGACY_RECORD = "files.json"
#: The formats stereoforge wrote in layout 1.
_LAYOUT_1_FORMATS = ("middlebury", "middlebury2014", "kitti", "webdataset")


def _root(root: str | Path | FsPath) -> Path | FsPath:
    """A dataset root as a path object: a folder (:class:`~pathlib.Path`) or an fsspec URL."""
    return root if isinstance(root, (Path, FsPath)) else dataset_path(root)


def sample_parent(root: str | Path, fmt: str) -> Path:
    """The folder holding the sample folders of a dataset of format ``fmt``
    (:attr:`synth.formats.base.Layout.sample_parent`)."""
    try:
        return _root(root) / get_layout(fmt).sample_parent
    except ValueError:
        raise ValueError(f"fmt: expected one of {', '.join(DATASET_FORMATS)}, got {fmt!r}") from None


def sample_dir(root: str | Path, fmt: str, index: int) -> Path:
    """The folder of sample ``index``: ``MiddEval3/trainingF/NNNNNN``, ``2014/NNNNNN``,
    ``training/samples/NNNNNN`` ... (:meth:`synth.formats.base.Layout.sample_dir`)."""
    return sample_parent(root, fmt) / f"{int(index):06d}"


def tools_root(root: str | Path, fmt: str) -> Path:
    """The folder of a dataset of format ``fmt`` that the tools read (``MiddEval3``, ``2014``,
    ``training``, ``FlyingThings3D`` ...; ``.staging`` of ``webdataset``): it holds the files of
    its samples only."""
    return _root(root) / get_layout(fmt).tools_root


def record_path(root: str | Path, index: int) -> Path:
    """The completion record of sample ``index``: ``records/NNNNNN.json``."""
    return _root(root) / RECORDS / f"{int(index):06d}.json"


def dataset_format(root: str | Path) -> str:
    """The format (one of :data:`synth.formats.DATASET_FORMATS`) named by
    ``root/dataset.json``.

    Raises :exc:`DatasetError` when there is no ``dataset.json`` or it names another format.
    """
    path = _root(root) / "dataset.json"
    if not path.is_file():
        raise DatasetError(f"{root} has no dataset.json; pass a directory made by run_dataset")
    fmt = read_json_object(path, what="dataset header", keys={"format": str})["format"]
    if fmt not in DATASET_FORMATS:
        raise DatasetError(f"{path} names format {fmt!r}; expected one of "
                           f"{', '.join(DATASET_FORMATS)}")
    return fmt


def _legacy_samples(root: Path) -> list[str]:
    return sorted(p.name for p in root.iterdir() if p.is_dir() and _SAMPLE_NAME.match(p.name)) \
        if root.is_dir() else []


def _refuse_legacy(root: Path, what: str) -> DatasetError:
    return DatasetError(f"{root} is a dataset of the previous layout ({what}), which RAFT-Stereo "
                        f"and MiddEval3 cannot read; convert it in place with `stereoforge dataset "
                        f"--upgrade {root}`")


def check_layout(root: str | Path) -> None:
    """Raise :exc:`DatasetError` (naming ``stereoforge dataset --upgrade DIR``) on a layout-1 dataset.

    A layout-1 dataset has a ``dataset.json`` without ``layout`` or sample folders ``NNNNNN/``
    at its root. A directory without ``dataset.json`` and no such folders passes (a new dataset).
    """
    root = _root(root)
    legacy = _legacy_samples(root)
    if legacy:
        raise _refuse_legacy(root, f"sample folders {legacy[0]}/ ... at its root")
    header = root / "dataset.json"
    if header.is_file() and read_json_object(header, what="dataset header").get("layout") is None:
        raise _refuse_legacy(root, "dataset.json has no layout version")


def sample_dirs(root: str | Path) -> Iterator[Path]:
    """The complete sample folders of a dataset (holding ``sample.json``), unsorted.

    Raises :exc:`DatasetError` on a layout-1 dataset (see :func:`check_layout`).
    """
    root = _root(root)
    if _legacy_samples(root):
        check_layout(root)
    for parent in dict.fromkeys(sample_parent(root, name) for name in DATASET_FORMATS):
        if parent.is_dir():
            for d in parent.iterdir():
                if _SAMPLE_NAME.match(d.name) and (d / "sample.json").is_file():
                    yield d


def write_scene_list(root: str | Path, fmt: str, names: list[str]) -> None:
    """The files of the whole dataset (:meth:`synth.formats.base.Layout.finish_files`: the
    scene list ``MiddEval3/official_train.txt`` RAFT-Stereo's Middlebury loader keeps, the list
    files of ``sceneflow``), from the complete samples' folder names."""
    for rel, data in get_layout(fmt).finish_files(sorted(names)).items():
        path = _root(root) / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        write_bytes(path, data)


def upgrade_dataset(root: str | Path) -> int:
    """Convert a layout-1 dataset in place to this layout; return the number of samples moved.

    Each sample folder is moved by one rename (a sample is always whole, in one place or the
    other); then its completion record ``files.json``, if it has one, is rewritten with the new
    paths to ``records/NNNNNN.json`` (same sizes and SHA-256: the files keep their bytes) and
    removed from the folder. ``dataset.json`` gets its ``layout`` last, so an interrupted upgrade
    is finished by running it again. The manifests do not change (their ``dir`` is the sample's
    name); ``official_train.txt`` is written. A sample without a record (written before records
    existed) is rendered again by the next run. A dataset already in this layout is left as it
    is (0).

    Raises
    ------
    DatasetError
        ``root`` holds no ``dataset.json`` or a format this version does not know.
    """
    root = Path(root)
    path = root / "dataset.json"
    if not path.is_file():
        raise DatasetError(f"{root} has no dataset.json; pass a directory made by run_dataset")
    header = read_json_object(path, what="dataset header")
    fmt = header.get("format")
    if fmt not in _LAYOUT_1_FORMATS:
        raise DatasetError(f"{path} names format {fmt!r}; only {', '.join(_LAYOUT_1_FORMATS)} "
                           "datasets of layout 1 exist to upgrade")
    parent = sample_parent(root, fmt)
    parent.mkdir(parents=True, exist_ok=True)
    moved = 0
    for name in _legacy_samples(root):
        target = parent / name
        if target.exists():
            raise DatasetError(f"{root / name} and {target} both exist; remove the one that is "
                               "not complete (no sample.json) and rerun the upgrade")
        os.replace(root / name, target)
        moved += 1
    prefix = parent.relative_to(root).as_posix()
    for folder in sorted(parent.iterdir()):
        if _SAMPLE_NAME.match(folder.name) and (folder / _LEGACY_RECORD).is_file():
            _move_record(root, folder, prefix)
    names = sorted(d.name for d in parent.iterdir()
                   if _SAMPLE_NAME.match(d.name) and (d / "sample.json").is_file())
    write_scene_list(root, fmt, names)
    if header.get("layout") != LAYOUT_VERSION:
        header["layout"] = LAYOUT_VERSION
        atomic_write_bytes(path, json_bytes(header))
    return moved


def _move_record(root: Path, folder: Path, prefix: str) -> None:
    """``folder/files.json`` (layout 1) to ``records/NNNNNN.json`` with the layout-2 paths."""
    old = folder / _LEGACY_RECORD
    try:
        record = json.loads(old.read_bytes())
        files = {(f"{prefix}/{name}" if name.startswith(f"{folder.name}/") else name): entry
                 for name, entry in record["files"].items()}
        record = {"files": dict(sorted(files.items())), "index": record["index"]}
    except (ValueError, KeyError, TypeError, AttributeError):
        old.unlink()  # unreadable: the sample counts as incomplete and is rendered again
        return
    target = record_path(root, int(folder.name))
    target.parent.mkdir(exist_ok=True)
    atomic_write_bytes(target, json_bytes(record), fsync=False)
    old.unlink()
