"""``drivingstereo:DIR`` (read only): DrivingStereo frames (Yang et al., CVPR 2019).

::

    DIR/left_images/<name>.jpg      right_images/<name>.jpg     disparity_maps/<name>.png
    DIR/calib/<sequence>.txt        (the calibration of the frames' size)

and the archives' own names for the same three folders (``train-left-image/``,
``train-right-image/``, ``train-disparity-map/``; ``left-image-half-size/``, ... of the test and
weather sets), with the frames directly in them or one folder per sequence. ``<name>`` is
``<sequence>_<time>``. The disparity is a 16-bit PNG of ``d * 256``, 0 = none (LiDAR: a fifth of
the pixels or so). The calibration file whose ``S_rect_101`` is the image size gives
``fx, fy, cx, cy`` (``P_rect_101``) and the baseline ``|T_103|``, with which the depth maps agree
(``fx * B / d``; a half-size file's ``P_rect_103`` holds twice ``fx * B``). The field reports D1
(error > 3 px and > 5 %).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from matcher.io import StereoSample, read_disparity, read_image
from matcher.io.sample import check_sample_shapes
from synth.formats.base import Capacity, Layout, SceneRef

__all__ = ["DrivingStereoLayout", "LAYOUT", "FOLDERS"]

#: (left images, right images, disparity maps) folder names, in the order they are looked for.
FOLDERS = (("left_images", "right_images", "disparity_maps"),
           ("train-left-image", "train-right-image", "train-disparity-map"),
           ("test-left-image", "test-right-image", "test-disparity-map"),
           ("left-image-half-size", "right-image-half-size", "disparity-map-half-size"),
           ("left-image-full-size", "right-image-full-size", "disparity-map-full-size"))
#: Folders holding the calibration files ``<sequence>.txt``.
CALIB_FOLDERS = ("calib", "half-image-calib", "full-image-calib")


def _others(key: str) -> tuple[str, str]:
    """The right image and the disparity of the left image ``key`` (a path from the root)."""
    first, _, rest = key.partition("/")
    left, right, disp = next(f for f in FOLDERS if f[0] == first)
    return f"{right}/{rest}", f"{disp}/{rest.removesuffix('.jpg')}.png"


def read_calib_file(path: Path) -> dict[str, np.ndarray]:
    """The ``KEY: v v v`` lines of a DrivingStereo (KITTI raw style) calibration file."""
    out = {}
    for line in path.read_text(encoding="ascii", errors="replace").splitlines():
        key, sep, values = line.partition(":")
        try:
            out[key.strip()] = np.array([float(v) for v in values.split()], np.float64)
        except ValueError:  # calib_time and other text fields
            continue
    return out


def _calib(root: Path, stem: str, shape: tuple[int, ...]) -> dict[str, float] | None:
    """``fx, fy, cx, cy, baseline`` from the sequence's calibration of this image size."""
    sequence = stem.split("_", 1)[0]
    for folder in CALIB_FOLDERS:
        path = root / folder / f"{sequence}.txt"
        if not path.is_file():
            continue
        c = read_calib_file(path)
        size, p, t = c.get("S_rect_101"), c.get("P_rect_101"), c.get("T_103")
        if size is None or p is None or t is None or len(p) != 12 or len(t) != 3:
            continue
        if (int(round(size[0])), int(round(size[1]))) == (shape[1], shape[0]):
            return {"fx": float(p[0]), "fy": float(p[5]), "cx": float(p[2]), "cy": float(p[6]),
                    "baseline": float(np.linalg.norm(t))}
    return None


class DrivingStereoLayout(Layout):
    """DrivingStereo's left, right and disparity folders."""

    name = "drivingstereo"
    title = "DrivingStereo"
    capacity = Capacity(right_disparity=False, disp_quantum=1 / 256)
    writable = False
    spec_form = "drivingstereo:DIR"
    metric = "d1"

    def recognises(self, root: Path) -> bool:
        return any((Path(root) / f[0]).is_dir() and (Path(root) / f[2]).is_dir() for f in FOLDERS)

    def discover(self, root: Path) -> list[str]:
        """The left images (``<left>/<name>.jpg`` or ``<left>/<sequence>/<name>.jpg``) with a
        right image and a disparity map."""
        root = Path(root)
        keys = []
        for left, _, _ in FOLDERS:
            for pattern in ("*.jpg", "*/*.jpg"):
                keys += [p.relative_to(root).as_posix() for p in sorted((root / left).glob(pattern))]
        return [k for k in keys if all((root / o).is_file() for o in _others(k))]

    def open_spec(self, spec: str, rest: str) -> list[SceneRef]:
        return [self.ref(Path(r.root), r.key, scene=f"drivingstereo:{r.name}", name=r.name)
                for r in super().open_spec(spec, rest)]

    def ref(self, root: Path, key: str, *, scene: str, name: str | None = None,
            divisor: float | None = None, note: str | None = None) -> SceneRef:
        return super().ref(root, key, scene=scene, name=name or Path(key).stem, divisor=divisor,
                           note=note)

    def read_key(self, root: Path, key: str) -> StereoSample:
        root = Path(root)
        right, disp = _others(key)
        left_image, right_image = read_image(root / key), read_image(root / right)
        gt = read_disparity(root / disp)
        check_sample_shapes(root / key, left_image, right_image, gt)
        stem = Path(key).stem
        return StereoSample(left_image, right_image, gt, None, stem,
                            {"dataset": "drivingstereo", "layout": self.name, "path": key},
                            calib=_calib(root, stem, left_image.shape))


LAYOUT = DrivingStereoLayout()
