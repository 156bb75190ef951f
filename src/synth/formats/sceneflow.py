"""``--format sceneflow``: FlyingThings3D's tree, the layout most training codebases read as it is.

::

    SceneFlow/FlyingThings3D/frames_cleanpass/TRAIN/A/0000/left/0000.png   the render before the
    SceneFlow/FlyingThings3D/frames_cleanpass/TRAIN/A/0000/right/0000.png  sensor and photometric
                                                                           models
    SceneFlow/FlyingThings3D/frames_finalpass/TRAIN/A/0000/left/0000.png   the config's images
    SceneFlow/FlyingThings3D/frames_finalpass/TRAIN/A/0000/right/0000.png  (the other layouts')
    SceneFlow/FlyingThings3D/disparity/TRAIN/A/0000/left/0000.pfm          left and right ground
    SceneFlow/FlyingThings3D/disparity/TRAIN/A/0000/right/0000.pfm         truth, inf = none
    SceneFlow/sceneflow_finalpass_train.txt  ...                           GwcNet-style lists
    samples/000000/   calib.txt scene.json sample.json [preview.png]       stereoforge's own

Which codebase takes which root: RAFT-Stereo's ``SceneFlowDatasets(root=OUT/SceneFlow)`` and
unimatch's ``FlyingThings3D(data_dir=OUT/SceneFlow/FlyingThings3D)``, IGEV-Stereo's
``SceneFlowDatasets(root=OUT/SceneFlow/FlyingThings3D)``, torchvision's
``SceneFlowStereo(root=OUT)``, and the list files of GwcNet, ACVNet, CFNet and OpenStereo with
``datapath=OUT/SceneFlow`` (each line ``FlyingThings3D/frames_.../left/NNNN.png
FlyingThings3D/frames_.../right/NNNN.png FlyingThings3D/disparity/.../left/NNNN.pfm``).

RAFT-Stereo and IGEV-Stereo find the right image and the disparity by replacing ``left`` and the
pass's name in the whole path, so no name this layout chooses contains ``left``, ``right``,
``frames_`` or ``.png`` except where FlyingThings3D has them (the output folder a user chooses must
not either: docs/formats.md).

**Split and sequences**: samples go in blocks of 25 by index; the last 4 of a block
(``index % 25 >= 21``: 16 %, as FlyingThings3D's 4,370 of 26,760) go to ``TEST``, the others to
``TRAIN``. Within a split, samples are numbered in index order (position ``p``); ten make a
sequence (``p // 10``; frame ``p % 10``), and sequence ``s`` is ``"ABC"[s % 3]/{s // 3:04d}``.
So the place of a sample depends on its index only (:func:`place`): deterministic whatever the
workers, and a dataset extended keeps every sample where it was.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matcher.io import (StereoSample, encode_pfm, encode_png,
                        read_image, read_pfm)
from synth.formats.base import Capacity, Layout, swap_folder, write_tree
from synth.formats.middlebury import calib_txt

__all__ = ["SceneFlowLayout", "LAYOUT", "place", "TEST_PER_BLOCK", "BLOCK", "PASSES"]

#: Samples per block, and how many of each block go to ``TEST``.
BLOCK, TEST_PER_BLOCK = 25, 4
#: Frames per sequence folder, as in FlyingThings3D.
FRAMES = 10
#: The two passes: the render before the sensor and photometric models, and the final images.
PASSES = ("frames_cleanpass", "frames_finalpass")
_ROOT = "SceneFlow"
_THINGS = f"{_ROOT}/FlyingThings3D"


def place(index: int) -> tuple[str, str, int, int]:
    """``(split, letter, sequence, frame)`` of sample ``index`` (see the module docstring).

    Examples
    --------
    >>> place(0), place(20), place(21), place(25), place(46)
    (('TRAIN', 'A', 0, 0), ('TRAIN', 'C', 0, 0), ('TEST', 'A', 0, 0), ('TRAIN', 'C', 0, 1), ('TEST', 'A', 0, 4))
    """
    block, r = divmod(int(index), BLOCK)
    train = BLOCK - TEST_PER_BLOCK
    if r < train:
        split, position = "TRAIN", block * train + r
    else:
        split, position = "TEST", block * TEST_PER_BLOCK + r - train
    sequence, frame = divmod(position, FRAMES)
    return split, "ABC"[sequence % 3], sequence // 3, frame


def _relative(kind: str, index: int, view: str) -> str:
    """The path (from ``SceneFlow/FlyingThings3D``) of sample ``index``'s ``kind`` (a pass or
    ``disparity``) file of ``view``."""
    split, letter, sequence, frame = place(index)
    ext = "pfm" if kind == "disparity" else "png"
    return f"{kind}/{split}/{letter}/{sequence:04d}/{view}/{frame:04d}.{ext}"



class SceneFlowLayout(Layout):
    """FlyingThings3D's tree: both passes, left and right disparity PFMs, list files."""

    name = "sceneflow"
    title = "SceneFlow (FlyingThings3D)"
    spec_form = "sceneflow:DIR"
    capacity = Capacity(right_disparity=True)
    tools_root = _ROOT
    sample_parent = "samples"
    placed = (_ROOT,)

    def count_note(self, count: int) -> str | None:
        """A dataset of fewer samples than the first TEST index + 1 has an empty TEST split:
        RAFT-Stereo and IGEV-Stereo would validate on nothing, unimatch divide by zero."""
        first = BLOCK - TEST_PER_BLOCK  # sample 21: the first of TEST
        if count > first:
            return None
        return (f"note: --format sceneflow puts samples {first}-{BLOCK - 1} of every {BLOCK} in "
                f"TEST (FlyingThings3D's 16 %, fixed by the index so that a dataset extended "
                f"keeps every sample where it was); with {count} sample(s) the TEST split is "
                f"empty, so a training codebase validates on nothing: render --count "
                f"{first + 1} or more for a TEST split")

    def write_files(self, pair: Any, dest: Path, *, scene: Any, index: int, clean: Any,
                    fsync: bool, image_deflate: str | None = None) -> list[Path]:
        files = {}
        for kind, images in zip(PASSES, (clean, pair)):
            for view, image in (("left", images.left), ("right", images.right)):
                files[f"{_THINGS}/{_relative(kind, index, view)}"] = encode_png(
                    image, deflate=image_deflate)
        for view, disp in (("left", pair.disp_left), ("right", pair.disp_right)):
            files[f"{_THINGS}/{_relative('disparity', index, view)}"] = encode_pfm(disp)
        files["calib.txt"] = calib_txt(pair)
        return write_tree(dest, files, fsync=fsync)

    def finish_files(self, names: list[str]) -> dict[str, bytes]:
        """GwcNet-style list files (``left right disparity`` a line, paths from
        ``SceneFlow/``), one per pass and split: ``SceneFlow/sceneflow_<pass>_<split>.txt``."""
        lines: dict[str, list[str]] = {}
        for pass_ in PASSES:
            for split in ("train", "test"):
                lines[f"{_ROOT}/sceneflow_{pass_.removeprefix('frames_')}_{split}.txt"] = []
        for name in sorted(names, key=int):
            index = int(name)
            split = place(index)[0].lower()
            for pass_ in PASSES:
                row = [f"FlyingThings3D/{_relative(kind, index, view)}"
                       for kind, view in ((pass_, "left"), (pass_, "right"),
                                          ("disparity", "left"))]
                lines[f"{_ROOT}/sceneflow_{pass_.removeprefix('frames_')}_{split}.txt"].append(
                    " ".join(row))
        return {path: "".join(f"{line}\n" for line in rows).encode() for path, rows in lines.items()}

    def key(self, index: int) -> str:
        return f"{_THINGS}/{_relative(PASSES[1], index, 'left')}"

    def read_key(self, root: Path, key: str) -> StereoSample:
        """``key``: the left image's path (from ``root``) in either pass; the right image and
        both disparities are found by swapping its folders (``left`` -> ``right``, the pass ->
        ``disparity``, ``.png`` -> ``.pfm``)."""
        root = Path(root)
        pass_ = next((p for p in PASSES if p in key.split("/")), None)
        if pass_ is None:
            raise ValueError(f"{key}: not under frames_cleanpass/ or frames_finalpass/")
        right = swap_folder(key, "left", "right")
        disp = swap_folder(key, pass_, "disparity").removesuffix(".png") + ".pfm"
        disp_right = swap_folder(disp, "left", "right")
        left_image, right_image = read_image(root / key), read_image(root / right)
        disp_left = read_pfm(root / disp)
        d1 = read_pfm(root / disp_right) if (root / disp_right).is_file() else None
        files = {"left view": root / key, "right view": root / right,
                 "left disparity": root / disp, "right disparity": root / disp_right}
        return StereoSample(left_image, right_image, disp_left, d1, Path(key).stem,
                            {"dataset": "sceneflow", "layout": self.name, "pass": pass_,
                             "path": key, "files": files})

    def recognises(self, root: Path) -> bool:
        """A FlyingThings3D tree: ``frames_*pass/`` and ``disparity/`` under ``root``,
        ``root/FlyingThings3D`` or ``root/SceneFlow/FlyingThings3D``."""
        return any((base / "disparity").is_dir() and any((base / p).is_dir() for p in PASSES)
                   for base in (root, root / "FlyingThings3D", root / _THINGS))

    def discover(self, root: Path) -> list[str]:
        """Left images of the final pass (else the clean pass) with a disparity PFM, under
        ``root``, ``root/FlyingThings3D`` or ``root/SceneFlow/FlyingThings3D``."""
        root = Path(root)
        for base in (root, root / "FlyingThings3D", root / _THINGS):
            for pass_ in PASSES[::-1]:
                found = sorted(p for p in (base / pass_).glob("*/*/*/left/*.png")) \
                    if (base / pass_).is_dir() else []
                keys = [p.relative_to(root).as_posix() for p in found]
                keys = [k for k in keys if (root / (swap_folder(k, pass_, "disparity").removesuffix(
                    ".png") + ".pfm")).is_file()]
                if keys:
                    return keys
        return []


LAYOUT = SceneFlowLayout()
