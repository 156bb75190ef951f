"""``--format kitti``: KITTI 2015 training frames, where RAFT-Stereo and the KITTI devkit look.

::

    training/image_2/000000_10.png  image_3/  disp_occ_0/  disp_noc_0/  obj_map/
    training/calib_cam_to_cam/000000.txt
    training/samples/000000/        scene.json sample.json [preview.png]

Disparities are uint16 PNGs of ``round(d * 256)`` (0 = no ground truth): at most 255.996 px, in
steps of 1/256 px. Frame ``NNNNNN`` is sample ``NNNNNN``; the tools read ``training/``.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from matcher.io import (KITTI_MAX_DISPARITY, StereoSample, format_kitti_calib, load_kitti_2015,
                        read_kitti_calib, write_kitti)
from scenes import plane_equation
from synth.formats.base import Capacity, Layout, SceneRef, spec_error, without_sky

__all__ = ["KittiLayout", "LAYOUT", "KITTI_ROOT", "kitti_calib_for", "foreground_map"]

#: Folder of a KITTI output that holds ``image_2/`` ... (KITTI's and RAFT-Stereo's ``training/``).
KITTI_ROOT = "training"
#: |d - d_plane| (px) below which a pixel lies on a plane object (the golden disparity tolerance).
_ON_PLANE_PX = 1e-3


def kitti_calib_for(pair: Any) -> str:
    """``calib_cam_to_cam`` text of a rendered pair (:func:`matcher.io.format_kitti_calib`)."""
    rig = pair.rig
    return format_kitti_calib(fx=rig.fx, fy=rig.fy, cx=rig.cx, cy=rig.cy, baseline=rig.baseline,
                              width=rig.width, height=rig.height)


def foreground_map(pair: Any, scene: Any) -> np.ndarray:
    """KITTI ``obj_map`` of a rendered pair: 0 background, 1 foreground.

    The renderer does not output object ids yet, so objects are split by kind: every ``plane``
    object (walls, ground planes) is background, every other object (boxes, spheres, cylinders,
    Moebius strips, terrain) foreground. A pixel with ground truth is background when its
    disparity lies within 1e-3 px of the exact disparity of one of the scene's planes (the
    unbounded plane: a foreground surface exactly on a plane's extension counts as background),
    foreground otherwise; pixels without ground truth are 0, as in KITTI.

    Returns
    -------
    (H, W) uint8 array
    """
    disp = np.asarray(pair.disp_left, dtype=np.float64)
    background = ~np.isfinite(disp)
    for obj in scene.objects:
        if obj.kind == "plane":
            n, c = plane_equation(obj)
            with np.errstate(invalid="ignore"):  # inf - inf where neither is there: not on it
                on_plane = np.abs(disp - pair.rig.plane_disparity(n, c)) <= _ON_PLANE_PX
            background |= on_plane
    return np.where(background, 0, 1).astype(np.uint8)


class KittiLayout(Layout):
    """KITTI 2015 frames (:func:`matcher.io.write_kitti`)."""

    name = "kitti"
    title = "KITTI 2015"
    spec_form = "kitti:DIR[:FIRST-LAST]"
    metric = "d1"
    capacity = Capacity(right_disparity=False, disp_quantum=1 / 256, disp_max=KITTI_MAX_DISPARITY)
    tools_root = KITTI_ROOT
    sample_parent = f"{KITTI_ROOT}/samples"
    placed = (KITTI_ROOT,)

    @property
    def kind(self) -> str:
        return "kitti2015"

    def recognises(self, root: Path) -> bool:
        """A KITTI ``training/`` folder (``image_2/``, ``disp_occ_0/``), or the folder holding
        one."""
        return any((base / "image_2").is_dir() and (base / "disp_occ_0").is_dir()
                   for base in (Path(root), Path(root) / KITTI_ROOT))

    def open_spec(self, spec: str, rest: str) -> list[SceneRef]:
        """``kitti:DIR[:FIRST-LAST]``: the frames of a KITTI 2015 ``training/`` folder (or of the
        folder holding it) with ``disp_occ_0``, or those from FIRST to LAST."""
        path, first, last = rest, 0, 999999
        head, _, tail = rest.rpartition(":")
        ranged = bool(head) and not Path(rest).is_dir()  # DIR:FIRST-LAST
        if ranged:
            bounds = re.fullmatch(r"([0-9]+)-([0-9]+)", tail)
            if bounds is None or int(bounds.group(1)) > int(bounds.group(2)):
                raise spec_error(spec, f"FIRST-LAST must be two frame numbers, FIRST <= LAST "
                                       f"(e.g. 0-9), got {tail!r}")
            path, first, last = head, int(bounds.group(1)), int(bounds.group(2))
        root = Path(path)
        if not (root / "image_2").is_dir() and (root / KITTI_ROOT / "image_2").is_dir():
            root = root / KITTI_ROOT  # the folder holding training/
        if not (root / "image_2").is_dir():
            raise spec_error(spec, f"{root} is not a KITTI 2015 training folder (no image_2/); "
                                   "give the folder holding image_2/, image_3/ and disp_occ_0/")
        frames = [k for k in self.discover(root) if first <= int(k) <= last]
        if not frames:
            raise spec_error(spec, f"no KITTI frame with disp_occ_0/NNNNNN_10.png in {root}"
                                   + (f" between {first} and {last}" if ranged else ""))
        return [self.ref(root, k, scene=f"kitti:{root.name}/{k}") for k in frames]

    def check_rig(self, rig: Any, *, source: str) -> None:
        """KITTI rigs routinely reach past 255.996 px at their near plane (a car's bonnet), so
        the rig bound is not refused here: a sample whose ground truth goes beyond it fails
        alone (:func:`matcher.io.encode_kitti_disparity`), naming the largest value; nothing is
        clipped."""

    def write_files(self, pair: Any, dest: Path, *, scene: Any, index: int, clean: Any,
                    fsync: bool, image_deflate: str | None = None) -> list[Path]:
        pair = without_sky(pair)  # KITTI codes 0 as "no ground truth"
        return list(write_kitti(dest / KITTI_ROOT, index, left=pair.left, right=pair.right,
                                disp_left=pair.disp_left, mask_left=pair.mask_left,
                                obj_map=foreground_map(pair, scene), calib=kitti_calib_for(pair),
                                fsync=fsync, image_deflate=image_deflate))

    def key(self, index: int) -> str:
        return f"{KITTI_ROOT}/{int(index):06d}"

    def read_key(self, root: Path, key: str) -> StereoSample:
        folder, _, frame = key.rpartition("/")
        base = Path(root) / folder if folder else Path(root)
        s = load_kitti_2015(base, int(frame))
        calib_file = base / "calib_cam_to_cam" / f"{int(frame):06d}.txt"
        calib = None
        if calib_file.is_file():
            p2, p3 = (read_kitti_calib(calib_file)[k] for k in ("P_rect_02", "P_rect_03"))
            fx = float(p2[0, 0])
            calib = {"fx": fx, "fy": float(p2[1, 1]), "cx": float(p2[0, 2]),
                     "cy": float(p2[1, 2]), "baseline": float(-p3[0, 3] / fx) if fx else 0.0}
        return StereoSample(s.left, s.right, s.disp_left, s.disp_right, s.name,
                            {**s.meta, "layout": self.name}, s.mask_left, calib=calib)

    def discover(self, root: Path) -> list[str]:
        """Frames with ``disp_occ_0/NNNNNN_10.png`` under ``root`` (the ``training/`` folder, or
        the folder holding it)."""
        root = Path(root)
        base = root if (root / "image_2").is_dir() or not (root / KITTI_ROOT).is_dir() \
            else root / KITTI_ROOT
        prefix = base.relative_to(root).as_posix()
        frames = sorted(int(p.name[:6]) for p in (base / "disp_occ_0").glob("[0-9]" * 6 + "_10.png"))
        return [f"{prefix}/{i:06d}" if prefix != "." else f"{i:06d}" for i in frames]


LAYOUT = KittiLayout()
