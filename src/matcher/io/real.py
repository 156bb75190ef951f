"""Real scenes with ground truth named by one string: ``middlebury:DIR``, ``kitti:DIR``,
``skimage:motorcycle``.

- ``middlebury:DIR[:DIVISOR]``: Middlebury scenes. ``DIR`` is one scene folder or a folder of
  scene folders (one level), or a folder holding ``MiddEval3/training?/``. A scene of the
  2005/2006 layout (``view1.png``, ``view5.png``, ``disp1.png``) is read with its divisor,
  given after the last ``:`` or inferred from the folder names (``third``, ``half``, ``full``:
  :func:`matcher.io.infer_middlebury_2005_divisor`); a MiddEval3 / 2014 scene (``im0.png``,
  ``im1.png``, ``disp0GT.pfm`` or ``disp0.pfm``) as stored.
- ``kitti:DIR``: every frame of a KITTI 2015 training folder (``DIR`` or ``DIR/training``
  holding ``image_2/``, ``image_3/``, ``disp_occ_0/``).
- ``skimage:motorcycle``: Middlebury 2014 *Motorcycle* as scikit-image ships it
  (``skimage.data.stereo_motorcycle``, 741 x 500, no download).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from matcher.io.kitti import load_kitti_2015
from matcher.io.middlebury import load_middlebury_2005, load_middlebury_2014
from matcher.io.sample import StereoSample
from stereoforge.errors import ParameterError

__all__ = ["REAL_KINDS", "RealSpecError", "load_real", "real_scene_dirs"]

#: The prefixes a real-scene string may start with.
REAL_KINDS = ("middlebury", "kitti", "skimage")
_SKIMAGE = ("motorcycle",)
_KITTI_FRAME = re.compile(r"^(\d{6})_10\.png$")


class RealSpecError(ParameterError):
    """A real-scene string names nothing readable; the message says what was looked for."""


def _is_2005(folder: Path) -> bool:
    return (folder / "view1.png").is_file() and (folder / "disp1.png").is_file()


def _is_2014(folder: Path) -> bool:
    return (folder / "im0.png").is_file() and any(
        (folder / n).is_file() for n in ("disp0GT.pfm", "disp0.pfm"))


def real_scene_dirs(root: Path) -> list[Path]:
    """The Middlebury scene folders under ``root`` (itself, its subfolders, or MiddEval3's)."""
    if _is_2005(root) or _is_2014(root):
        return [root]
    found = sorted(p for p in root.iterdir() if p.is_dir() and (_is_2005(p) or _is_2014(p))) \
        if root.is_dir() else []
    if not found and (root / "MiddEval3").is_dir():
        for split in sorted((root / "MiddEval3").glob("training?")):
            found += sorted(p for p in split.iterdir() if p.is_dir() and _is_2014(p))
    return found


def _middlebury(spec: str, rest: str) -> list[StereoSample]:
    divisor = None
    head, sep, tail = rest.rpartition(":")
    if sep and re.fullmatch(r"\d+(\.\d+)?", tail):
        rest, divisor = head, float(tail)
    root = Path(rest).expanduser()
    if not root.exists():
        raise RealSpecError(f"{spec}: {root} does not exist")
    dirs = real_scene_dirs(root)
    if not dirs:
        raise RealSpecError(f"{spec}: no Middlebury scene in {root} (looked for view1.png + "
                            "disp1.png, or im0.png + disp0GT.pfm / disp0.pfm, in it, its "
                            "subfolders and MiddEval3/training?/)")
    out = []
    for d in dirs:
        if _is_2005(d):
            try:
                out.append(load_middlebury_2005(d, divisor=divisor))
            except ValueError as exc:
                if "divisor" not in str(exc):
                    raise
                raise RealSpecError(f"{spec}: {exc}; or give it as middlebury:DIR:3") from None
        else:
            out.append(load_middlebury_2014(d))
    return out


def _kitti(spec: str, rest: str) -> list[StereoSample]:
    root = Path(rest).expanduser()
    if (root / "training" / "image_2").is_dir():
        root = root / "training"
    occ = root / "disp_occ_0"
    if not occ.is_dir():
        raise RealSpecError(f"{spec}: {root} has no disp_occ_0/ (a KITTI 2015 training folder "
                            "holds image_2/, image_3/ and disp_occ_0/)")
    frames = sorted(int(m.group(1)) for p in occ.iterdir() if (m := _KITTI_FRAME.match(p.name)))
    if not frames:
        raise RealSpecError(f"{spec}: no NNNNNN_10.png frame in {occ}")
    return [load_kitti_2015(root, i) for i in frames]


def _skimage(spec: str, name: str) -> list[StereoSample]:
    if name != "motorcycle":
        raise RealSpecError(f"{spec}: scikit-image ships one stereo pair: skimage:motorcycle")
    import skimage.data

    left, right, disp = skimage.data.stereo_motorcycle()
    gt = np.where(np.isfinite(disp), disp, np.inf).astype(np.float32)
    return [StereoSample(left, right, gt, None, "Motorcycle",
                         {"dataset": "skimage", "scene": "motorcycle"})]


def load_real(spec: str) -> list[StereoSample]:
    """The scenes a real-scene string names (see the module docstring), in a stable order.

    Raises
    ------
    RealSpecError
        An unknown prefix, a folder without scenes, or a divisor that cannot be inferred.
    """
    kind, sep, rest = str(spec).partition(":")
    if not sep or kind not in REAL_KINDS or not rest.strip():
        raise RealSpecError(f"real scenes {spec!r}: expected middlebury:DIR[:DIVISOR], kitti:DIR "
                            "or skimage:motorcycle")
    rest = rest.strip()
    if kind == "middlebury":
        return _middlebury(spec, rest)
    if kind == "kitti":
        return _kitti(spec, rest)
    return _skimage(spec, rest)
