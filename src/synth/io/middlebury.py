"""Write a stereo pair in the Middlebury 2014 layout (read back by
:func:`matcher.io.load_middlebury_2014`).

Files written into ``out_dir`` (see ``docs/formats.md``)::

    im0.png, im1.png     left and right images (8-bit, RGB or grey)
    disp0.pfm, disp1.pfm left and right ground-truth disparity, float32, inf = no ground truth
    mask0nocc.png        occlusion mask of the left view: 255 visible, 128 occluded, 0 no GT
    calib.txt            cam0, cam1, doffs, baseline (mm), width, height, ndisp, vmin, vmax
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from matcher._validation import check_ground_truth, check_occlusion_mask
from matcher.io import encode_pfm, format_calib
from synth.io._atomic import write_all_atomic
from synth.io.png import encode_png

__all__ = ["REQUIRED_CALIB_KEYS", "check_stereo_images", "write_middlebury"]

#: Keys ``calib`` must provide; ``width``, ``height``, ``vmin``, ``vmax`` are filled in if absent.
REQUIRED_CALIB_KEYS: tuple[str, ...] = ("cam0", "cam1", "doffs", "baseline", "ndisp")


def check_stereo_images(left: object, right: object) -> tuple[np.ndarray, np.ndarray]:
    """Validate a pair of images to write: uint8, ``(H, W)`` or ``(H, W, 3)``, same shape.

    Examples
    --------
    >>> import numpy as np
    >>> check_stereo_images(np.zeros((2, 2), np.uint8), np.zeros((2, 2), np.uint8))[0].shape
    (2, 2)
    """
    for name, image in (("left", left), ("right", right)):
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8:
            got = f"dtype {image.dtype}" if isinstance(image, np.ndarray) else type(image).__name__
            raise TypeError(f"{name}: expected a uint8 image, got {got}; convert with np.clip(...).astype(np.uint8)")
        if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)) or 0 in image.shape:
            raise ValueError(f"{name}: expected shape (H, W) or (H, W, 3) (RGB), got {image.shape}")
    if left.shape != right.shape:  # type: ignore[union-attr]
        raise ValueError(f"left and right: expected the same shape, got {left.shape} and {right.shape}")  # type: ignore[union-attr]
    return left, right  # type: ignore[return-value]


def _complete_calib(calib: Mapping[str, object], shape: tuple[int, int], disp: np.ndarray) -> dict:
    if not isinstance(calib, Mapping):
        raise TypeError(f"calib: expected a dict, got {type(calib).__name__}")
    missing = [k for k in REQUIRED_CALIB_KEYS if k not in calib]
    if missing:
        raise ValueError(f"calib: missing keys {missing}; required: {list(REQUIRED_CALIB_KEYS)}")
    out = dict(calib)
    h, w = shape
    for key, value in (("width", w), ("height", h)):
        if key in out and int(out[key]) != value:  # type: ignore[call-overload]
            raise ValueError(f"calib[{key!r}]: expected {value} (the image size), got {out[key]}")
        out[key] = value
    if "vmin" not in out or "vmax" not in out:
        finite = disp[np.isfinite(disp)]
        if "vmin" not in out:
            out["vmin"] = math.floor(float(finite.min())) if finite.size else 0
        if "vmax" not in out:
            out["vmax"] = math.ceil(float(finite.max())) if finite.size else 0
    return out


def write_middlebury(
    out_dir: str | os.PathLike[str],
    *,
    left: np.ndarray,
    right: np.ndarray,
    disp_left: np.ndarray,
    disp_right: np.ndarray | None,
    mask_left: np.ndarray,
    calib: Mapping[str, object],
    fsync: bool = True,
) -> list[Path]:
    """Write one stereo pair as a Middlebury 2014 scene folder.

    Everything is validated and encoded before the first byte is written, and every file is
    written atomically, so an error leaves ``out_dir`` as it was.

    Parameters
    ----------
    out_dir : str or path-like
        Scene folder; created (with parents) if missing; existing files are replaced.
    left, right : (H, W, 3) or (H, W) uint8 array
        Images, RGB order.
    disp_left : (H, W) float array
        Left ground truth in pixels, ``>= 0``; ``inf`` (or NaN, written as ``inf``) exactly where
        ``mask_left == 0``.
    disp_right : (H, W) float array or None
        Right ground truth (``inf`` = none); ``disp1.pfm`` is skipped when None.
    mask_left : (H, W) uint8 array
        Codes 255 (visible in both views), 128 (occluded in the right view), 0 (no ground truth).
    calib : dict
        ``cam0``, ``cam1`` (3x3), ``doffs``, ``baseline`` (mm), ``ndisp``, plus any other keys
        (``isint``, ...). ``width``/``height`` are filled from the images (and must match if
        given); ``vmin``/``vmax`` default to the floor/ceil of the finite ``disp_left`` range.
    fsync : bool, default True
        ``fsync`` each file before renaming it into place.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order ``im0.png, im1.png, disp0.pfm, [disp1.pfm,]
        mask0nocc.png, calib.txt``.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> from matcher.io import load_middlebury_2014
    >>> img = np.zeros((2, 3, 3), np.uint8)
    >>> d = np.array([[1.0, 2.0, np.inf], [1.0, 2.0, 2.5]], np.float32)
    >>> mask = np.where(np.isfinite(d), 255, 0).astype(np.uint8)
    >>> cal = {"cam0": np.eye(3), "cam1": np.eye(3), "doffs": 0, "baseline": 100, "ndisp": 8}
    >>> with tempfile.TemporaryDirectory() as out:
    ...     files = write_middlebury(out, left=img, right=img, disp_left=d, disp_right=None,
    ...                              mask_left=mask, calib=cal)
    ...     s = load_middlebury_2014(out)
    >>> [f.name for f in files]
    ['im0.png', 'im1.png', 'disp0.pfm', 'mask0nocc.png', 'calib.txt']
    >>> s.disp_left[0].tolist(), s.meta["calib"]["vmax"]
    ([1.0, 2.0, inf], 3)
    """
    left, right = check_stereo_images(left, right)
    shape = left.shape[:2]
    mask_left = check_occlusion_mask(mask_left, "mask_left", shape=shape)
    disp0 = check_ground_truth(disp_left, "disp_left", shape=shape, mask=mask_left)
    disp1 = None if disp_right is None else check_ground_truth(disp_right, "disp_right", shape=shape)
    full_calib = _complete_calib(calib, shape, disp0)

    out = Path(out_dir)
    files: dict[Path, bytes] = {
        out / "im0.png": encode_png(left),
        out / "im1.png": encode_png(right),
        out / "disp0.pfm": encode_pfm(disp0),
    }
    if disp1 is not None:
        files[out / "disp1.pfm"] = encode_pfm(disp1)
    files[out / "mask0nocc.png"] = encode_png(mask_left)
    files[out / "calib.txt"] = format_calib(full_calib).encode("ascii")
    out.mkdir(parents=True, exist_ok=True)
    return write_all_atomic(files, fsync=fsync)
