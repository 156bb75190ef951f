"""``--format fsd``: FoundationStereo's FSD layout.

::

    FSD/0000/dataset/data/left/rgb/0000.jpg         left image, JPEG (quality 95, 4:4:4)
    FSD/0000/dataset/data/right/rgb/0000.jpg        right image
    FSD/0000/dataset/data/left/disparity/0000.png   left disparity x 1000, packed in R, G, B
                                                    in base 255 (R most significant), 0 = none
    samples/000000/   calib.txt scene.json sample.json [preview.png]     stereoforge's own

Sample ``i`` is frame ``i % 1000`` of scene ``i // 1000`` (four digits each). The root a
codebase takes is ``OUT/FSD`` (OpenStereo globs ``ROOT/*/dataset/data/``, then finds the right
image and the disparity by replacing ``left`` and ``rgb`` in the whole path: the output folder must
contain neither). Disparities in steps of 1/1000 px up to
:data:`matcher.io.FSD_MAX` (:func:`matcher.io.encode_fsd_disparity`); FSD has no right-view ground
truth.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matcher.io import (FSD_MAX, FSD_SCALE, StereoSample, encode_fsd_disparity,
                        encode_jpeg, read_fsd_disparity, read_image)
from synth.formats.base import (JPEG_QUALITY, Capacity, Layout, swap_folder, without_sky,
                                write_tree)
from synth.formats.middlebury import calib_txt

__all__ = ["FSDLayout", "LAYOUT", "FRAMES_PER_SCENE"]

#: Frames of one scene folder.
FRAMES_PER_SCENE = 1000
_ROOT = "FSD"
#: Where the left images are under the root a reader is given, in the order they are looked for.
_PATTERNS = ("*/dataset/data/left/rgb/*.jpg", f"{_ROOT}/*/dataset/data/left/rgb/*.jpg",
             "dataset/data/left/rgb/*.jpg", "left/rgb/*.jpg")



class FSDLayout(Layout):
    """FoundationStereo's ``<scene>/dataset/data/left|right/rgb/NNNN.jpg`` files."""

    name = "fsd"
    title = "FoundationStereo FSD"
    spec_form = "fsd:DIR"
    capacity = Capacity(right_disparity=False, disp_quantum=1 / FSD_SCALE, disp_max=FSD_MAX,
                        lossless=False)
    tools_root = _ROOT
    sample_parent = "samples"
    placed = (_ROOT,)

    def key(self, index: int) -> str:
        scene, frame = divmod(int(index), FRAMES_PER_SCENE)
        return f"{_ROOT}/{scene:04d}/dataset/data/left/rgb/{frame:04d}.jpg"

    def write_files(self, pair: Any, dest: Path, *, scene: Any, index: int, clean: Any,
                    fsync: bool, image_deflate: str | None = None) -> list[Path]:
        left = self.key(index)
        pair = without_sky(pair)  # FSD codes 0 as "no ground truth"
        files = {left: encode_jpeg(pair.left, quality=JPEG_QUALITY),
                 swap_folder(left, "left", "right"): encode_jpeg(pair.right, quality=JPEG_QUALITY),
                 swap_folder(left, "rgb", "disparity").removesuffix(".jpg") + ".png":
                     encode_fsd_disparity(pair.disp_left),
                 "calib.txt": calib_txt(pair)}
        return write_tree(dest, files, fsync=fsync)

    def read_key(self, root: Path, key: str) -> StereoSample:
        """``key``: the left image's path (from ``root``)."""
        root = Path(root)
        disp = swap_folder(key, "rgb", "disparity").removesuffix(".jpg") + ".png"
        right = swap_folder(key, "left", "right")
        files = {"left view": root / key, "right view": root / right, "left disparity": root / disp}
        return StereoSample(read_image(root / key), read_image(root / right),
                            read_fsd_disparity(root / disp), None, Path(key).stem,
                            {"dataset": "fsd", "layout": self.name, "path": key, "files": files})

    def recognises(self, root: Path) -> bool:
        """A left image of the layout (``*/dataset/data/left/rgb/*.jpg``, or one scene's)."""
        return any(next(Path(root).glob(p), None) is not None for p in _PATTERNS)

    def discover(self, root: Path) -> list[str]:
        """Left images with a right image and a disparity under ``root`` (the folder of
        scenes), ``root/FSD``, or ``root`` being one scene's folder."""
        root = Path(root)
        found: list[Path] = []
        for pattern in _PATTERNS:
            found = sorted(root.glob(pattern))
            if found:
                break
        keys = [p.relative_to(root).as_posix() for p in found]
        return [k for k in keys if (root / swap_folder(k, "left", "right")).is_file() and (
            root / (swap_folder(k, "rgb", "disparity").removesuffix(".jpg") + ".png")).is_file()]


LAYOUT = FSDLayout()
