"""Where a dataset's sample folders live, so that real stereo tools read the directory as it is.

Layout 2 (this version)::

    out/
      dataset.json  manifest.jsonl  manifest.csv  .lock      stereoforge's own files
      MiddEval3/                                              fmt="middlebury"
        official_train.txt        every complete sample's name, one a line
        trainingF/000000/         im0.png im1.png disp0GT.pfm ... scene.json sample.json
      training/                                               fmt="kitti"
        image_2/ image_3/ disp_occ_0/ disp_noc_0/ obj_map/ calib_cam_to_cam/
        samples/000000/           scene.json sample.json

``MiddEval3/trainingF/<scene>/`` and ``MiddEval3/official_train.txt`` are where RAFT-Stereo's
``Middlebury(root, split="F")`` looks, and ``trainingF/`` is what MiddEval3's ``runeval F`` walks
when the SDK is unpacked into ``MiddEval3/``; ``training/image_2`` is RAFT-Stereo's and the KITTI
devkit's root. Nothing of stereoforge's own sits in those folders. Layout 1 (stereoforge before
this version) put the sample folders ``000000/`` at the root, beside ``dataset.json``, where the
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

__all__ = ["LAYOUT_VERSION", "MIDDEVAL_ROOT", "MIDDEVAL_SCENES", "KITTI_TRAINING", "KITTI_SAMPLES", "sample_parent",
           "sample_dir", "sample_dirs", "check_layout", "write_scene_list", "upgrade_dataset"]

#: Version of the directory layout, ``layout`` in ``dataset.json`` (absent: layout 1).
LAYOUT_VERSION = 2
#: The MiddEval3 root of a Middlebury-format dataset, and its scene folder inside it.
MIDDEVAL_ROOT = "MiddEval3"
MIDDEVAL_SCENES = f"{MIDDEVAL_ROOT}/trainingF"
#: The KITTI root of a KITTI-format dataset (``image_2/`` ...), and its sample folders
#: (scene.json, sample.json) inside it.
KITTI_TRAINING = "training"
KITTI_SAMPLES = f"{KITTI_TRAINING}/samples"
_SAMPLE_NAME = re.compile(r"^\d{6}$")
#: Samples of a ``webdataset`` dataset not yet in a complete shard (:mod:`synth.dataset.shards`).
STAGING = ".staging"
_PARENTS = {"middlebury": MIDDEVAL_SCENES, "kitti": KITTI_SAMPLES, "webdataset": STAGING}


def sample_parent(root: str | Path, fmt: str) -> Path:
    """The folder holding the sample folders of a dataset of format ``fmt``."""
    try:
        return Path(root) / _PARENTS[fmt]
    except KeyError:
        raise ValueError(f"fmt: expected one of {', '.join(_PARENTS)}, got {fmt!r}") from None


def sample_dir(root: str | Path, fmt: str, index: int) -> Path:
    """The folder of sample ``index``: ``MiddEval3/trainingF/NNNNNN`` or ``training/samples/NNNNNN``."""
    return sample_parent(root, fmt) / f"{int(index):06d}"


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
    root = Path(root)
    legacy = _legacy_samples(root)
    if legacy:
        raise _refuse_legacy(root, f"sample folders {legacy[0]}/ ... at its root")
    header = root / "dataset.json"
    if header.is_file() and json.loads(header.read_text()).get("layout") is None:
        raise _refuse_legacy(root, "dataset.json has no layout version")


def sample_dirs(root: str | Path) -> Iterator[Path]:
    """The complete sample folders of a dataset (holding ``sample.json``), unsorted.

    Raises :exc:`DatasetError` on a layout-1 dataset (see :func:`check_layout`).
    """
    root = Path(root)
    if _legacy_samples(root):
        check_layout(root)
    for fmt in _PARENTS:
        parent = sample_parent(root, fmt)
        if parent.is_dir():
            for d in parent.iterdir():
                if _SAMPLE_NAME.match(d.name) and (d / "sample.json").is_file():
                    yield d


def write_scene_list(root: str | Path, fmt: str, names: list[str]) -> None:
    """``MiddEval3/official_train.txt``: the scene names RAFT-Stereo's Middlebury loader keeps."""
    if fmt == "middlebury":
        text = "".join(f"{n}\n" for n in sorted(names))
        (Path(root) / MIDDEVAL_ROOT).mkdir(exist_ok=True)
        atomic_write_bytes(Path(root) / MIDDEVAL_ROOT / "official_train.txt", text.encode(),
                           fsync=False)


def upgrade_dataset(root: str | Path) -> int:
    """Convert a layout-1 dataset in place to this layout; return the number of samples moved.

    Each sample folder is moved by one rename (a sample is always whole, in one place or the
    other), ``dataset.json`` gets its ``layout`` last, so an interrupted upgrade is finished by
    running it again. The sample files keep their bytes. The manifests do not change (their
    ``dir`` is the sample's name); ``official_train.txt`` is written. A dataset already in this
    layout is left as it is (0).

    Raises
    ------
    DatasetError
        ``root`` holds no ``dataset.json`` or a format this version does not know.
    """
    root = Path(root)
    path = root / "dataset.json"
    if not path.is_file():
        raise DatasetError(f"{root} has no dataset.json; pass a directory made by run_dataset")
    header = json.loads(path.read_text())
    fmt = header.get("format")
    if fmt not in _PARENTS:
        raise DatasetError(f"{path} names format {fmt!r}; only {', '.join(_PARENTS)} datasets of "
                           "layout 1 exist to upgrade")
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
    names = sorted(d.name for d in parent.iterdir()
                   if _SAMPLE_NAME.match(d.name) and (d / "sample.json").is_file())
    write_scene_list(root, fmt, names)
    if header.get("layout") != LAYOUT_VERSION:
        header["layout"] = LAYOUT_VERSION
        atomic_write_bytes(path, (json.dumps(header, indent=2, sort_keys=True) + "\n").encode())
    return moved
