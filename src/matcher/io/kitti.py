"""The KITTI 2015 stereo layout: read a training frame, write one.

Files of frame ``index`` under a dataset root (``NNNNNN`` = six-digit index; the root is the
``training/`` folder of a KITTI download)::

    image_2/NNNNNN_10.png      left image
    image_3/NNNNNN_10.png      right image
    disp_occ_0/NNNNNN_10.png   left disparity at every pixel with ground truth (mask 128 or 255)
    disp_noc_0/NNNNNN_10.png   left disparity at non-occluded pixels only (mask 255)
    obj_map/NNNNNN_10.png      8-bit object map: 0 background, 1..255 foreground objects
                               (the devkit splits D1 into bg/fg with it)
    calib_cam_to_cam/NNNNNN.txt  ``P_rect_02``/``P_rect_03`` (3x4 projections of the rectified
                               left/right camera, the left one the reference), ``S_rect_0x``,
                               ``R_rect_0x``; see :func:`format_kitti_calib`

KITTI's ``disp_occ_1``/``disp_noc_1`` hold the disparity of the *next time frame* (for scene flow),
not of the right view; a single stereo pair has no next frame, so they are not written.

Disparity PNGs are uint16 ``round(d * 256)``, 0 = no ground truth. They can hold at most
``65535 / 256 = 255.996`` px; a valid disparity below ``1 / 512`` px (which would round to the
invalid code 0) is stored as 1 (``1 / 256`` px) so that it stays valid.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from matcher._validation import check_ground_truth, check_occlusion_mask
from matcher.io.atomic import write_all_atomic
from matcher.io.png import KITTI_DIVISOR, check_deflate, encode_png, read_disparity, read_image
from matcher.io.sample import StereoSample, check_sample_shapes, check_stereo_images, require_dir

__all__ = ["KITTI_MAX_DISPARITY", "encode_kitti_disparity", "format_kitti_calib", "load_kitti_2015",
           "parse_kitti_calib", "read_kitti_calib", "write_kitti"]

#: Largest disparity a KITTI PNG can store.
KITTI_MAX_DISPARITY = 65535 / 256


def load_kitti_2015(root: str | os.PathLike[str], index: int, *, occ: bool = True) -> StereoSample:
    """Load frame ``index`` of a KITTI 2015 (or 2012-style) training folder.

    Reads ``image_2/NNNNNN_10.png`` (left), ``image_3/NNNNNN_10.png`` (right) and the disparity
    ``disp_occ_0/NNNNNN_10.png`` (``occ=True``: all pixels with ground truth) or
    ``disp_noc_0/NNNNNN_10.png`` (``occ=False``: non-occluded only), uint16 ``d * 256`` with
    0 = invalid.

    Returns
    -------
    StereoSample
        ``disp_left`` float32 pixels, ``inf`` where invalid; ``disp_right`` None. When both
        ``disp_occ_0`` and ``disp_noc_0`` exist, ``mask_left`` is derived from them: 255 where
        the noc map is valid, 128 where only the occ map is, 0 elsewhere.

    Examples
    --------
    >>> import tempfile, pathlib, cv2, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     for sub in ("image_2", "image_3", "disp_occ_0"):
    ...         pathlib.Path(d, sub).mkdir()
    ...     for sub in ("image_2", "image_3"):
    ...         _ = cv2.imwrite(f"{d}/{sub}/000007_10.png", np.zeros((1, 2, 3), np.uint8))
    ...     _ = cv2.imwrite(f"{d}/disp_occ_0/000007_10.png", np.array([[0, 640]], np.uint16))
    ...     load_kitti_2015(d, 7).disp_left.tolist()
    [[inf, 2.5]]
    """
    root = Path(root)
    require_dir(root, "root")
    if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)) or not 0 <= index <= 999999:
        raise ValueError(f"index: expected an integer in [0, 999999], got {index!r}")
    name = f"{int(index):06d}_10.png"
    left = read_image(root / "image_2" / name)
    right = read_image(root / "image_3" / name)
    occ_path, noc_path = root / "disp_occ_0" / name, root / "disp_noc_0" / name
    disp_left = read_disparity(occ_path if occ else noc_path, divisor=KITTI_DIVISOR)
    mask = None
    if occ_path.is_file() and noc_path.is_file():
        other = read_disparity(noc_path if occ else occ_path, divisor=KITTI_DIVISOR)
        d_occ, d_noc = (disp_left, other) if occ else (other, disp_left)
        mask = np.where(np.isfinite(d_noc), 255, np.where(np.isfinite(d_occ), 128, 0)).astype(np.uint8)
    check_sample_shapes(root, left, right, disp_left, mask)
    meta = {"dataset": "kitti2015", "occ": occ, "root": str(root), "index": int(index)}
    return StereoSample(left, right, disp_left, None, f"{int(index):06d}", meta, mask)


def _sci(value: float) -> str:
    """KITTI's ``%e`` look (``7.215377e+02``) with as many digits as the float needs to round-trip."""
    v = float(value)
    if not np.isfinite(v):
        raise ValueError(f"calib: expected finite numbers, got {v}")
    for digits in range(6, 18):
        text = f"{v:.{digits}e}"
        if float(text) == v:
            return text
    return repr(v)  # pragma: no cover - 17 digits always round-trip


def format_kitti_calib(
    *, fx: float, fy: float, cx: float, cy: float, baseline: float, width: int, height: int,
    cx_right: float | None = None,
) -> str:
    """The text of a ``calib_cam_to_cam/NNNNNN.txt`` for a rectified pair.

    The left camera (KITTI's cam 2) is the reference: ``P_rect_02 = [fx 0 cx 0; 0 fy cy 0;
    0 0 1 0]`` and ``P_rect_03`` the same with ``cx_right`` and ``tx = -fx * baseline`` (metres),
    as KITTI's projections put the camera offset in the last column. ``R_rect_0x`` are the
    identity (the images are already rectified), ``S_rect_0x`` the image size. Numbers are
    written in KITTI's ``%e`` style with the digits needed to round-trip.

    Examples
    --------
    >>> text = format_kitti_calib(fx=600, fy=600, cx=319.5, cy=239.5, baseline=0.1, width=640, height=480)
    >>> print(text.splitlines()[2])
    P_rect_02: 6.000000e+02 0.000000e+00 3.195000e+02 0.000000e+00 0.000000e+00 6.000000e+02 2.395000e+02 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
    >>> c = parse_kitti_calib(text)
    >>> float(c["P_rect_02"][0, 3] - c["P_rect_03"][0, 3]) / float(c["P_rect_02"][0, 0])
    0.1
    """
    cx_right = cx if cx_right is None else cx_right
    p2 = np.array([[fx, 0, cx, 0], [0, fy, cy, 0], [0, 0, 1, 0]], np.float64)
    p3 = np.array([[fx, 0, cx_right, -fx * baseline], [0, fy, cy, 0], [0, 0, 1, 0]], np.float64)
    size = f"{_sci(width)} {_sci(height)}"
    eye = " ".join(_sci(x) for x in np.eye(3).ravel())
    lines = []
    for cam, p in (("02", p2), ("03", p3)):
        lines += [f"S_rect_{cam}: {size}", f"R_rect_{cam}: {eye}",
                  f"P_rect_{cam}: " + " ".join(_sci(x) for x in p.ravel())]
    return "".join(line + "\n" for line in lines)


def parse_kitti_calib(text: str, *, where: str = "calib_cam_to_cam") -> dict[str, np.ndarray]:
    """Parse a KITTI calibration text (``key: numbers`` per line).

    Returns
    -------
    dict
        ``P_rect_0x`` as (3, 4), ``R_rect_0x`` as (3, 3), other keys as 1-D float64 arrays;
        non-numeric values (``calib_time``) are skipped.
    """
    shapes = {"P": (3, 4), "R": (3, 3), "K": (3, 3)}
    calib: dict[str, np.ndarray] = {}
    for lineno, line in enumerate(text.splitlines(), 1):
        key, sep, value = line.partition(":")
        if not sep:
            if line.strip():
                raise ValueError(f"{where}, line {lineno}: expected 'key: values', got {line!r}")
            continue
        try:
            numbers = np.array([float(x) for x in value.split()], np.float64)
        except ValueError:
            continue  # calib_time: 09-Jan-2012 13:57:47
        shape = shapes.get(key.strip()[:1])
        if shape is not None and numbers.size == shape[0] * shape[1]:
            numbers = numbers.reshape(shape)
        calib[key.strip()] = numbers
    return calib


def read_kitti_calib(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read a KITTI ``calib_cam_to_cam`` file (see :func:`parse_kitti_calib`)."""
    path = Path(path)
    return parse_kitti_calib(path.read_text(encoding="ascii"), where=str(path))


def encode_kitti_disparity(disparity: np.ndarray, *, name: str = "disparity") -> np.ndarray:
    """Convert float disparity (``inf``/NaN = none) to KITTI's uint16 codes.

    Parameters
    ----------
    disparity : (H, W) float array
        Disparity in pixels; finite values must lie in ``[0, 65535 / 256]``.
    name : str
        Name used in error messages.

    Returns
    -------
    (H, W) uint16 array
        ``round(d * 256)`` (at least 1) where finite, 0 elsewhere.

    Raises
    ------
    ValueError
        If a finite value is negative or above :data:`KITTI_MAX_DISPARITY`.

    Examples
    --------
    >>> import numpy as np
    >>> encode_kitti_disparity(np.array([[0.0, 1.5, np.inf]])).tolist()
    [[1, 384, 0]]
    """
    d = np.asarray(disparity, dtype=np.float64)
    finite = np.isfinite(d)
    out_of_range = finite & ((d < 0) | (d > KITTI_MAX_DISPARITY))
    if out_of_range.any():
        i, j = np.argwhere(out_of_range)[0]
        raise ValueError(
            f"{name}: KITTI PNGs store disparities in [0, {KITTI_MAX_DISPARITY:.3f}] px, got "
            f"{d[i, j]} at row {i}, column {j} ({int(out_of_range.sum())} such pixels); "
            "use the Middlebury layout (PFM) or a smaller baseline/focal length"
        )
    codes = np.zeros(d.shape, np.uint16)
    codes[finite] = np.maximum(np.rint(d[finite] * 256.0), 1).astype(np.uint16)
    return codes


def write_kitti(
    out_root: str | os.PathLike[str],
    index: int,
    *,
    left: np.ndarray,
    right: np.ndarray,
    disp_left: np.ndarray,
    mask_left: np.ndarray,
    obj_map: np.ndarray | None = None,
    calib: str | None = None,
    fsync: bool = True,
    image_deflate: str | None = None,
) -> list[Path]:
    """Write frame ``index`` of a KITTI 2015-style training folder.

    With ``obj_map`` and ``calib`` the folder is what the KITTI 2015 devkit's
    ``evaluate_scene_flow`` and RAFT-Stereo's KITTI loader read as they are.

    Everything is validated and encoded before the first write (so a disparity KITTI cannot
    store leaves ``out_root`` untouched), and each file is written atomically.

    Parameters
    ----------
    out_root : str or path-like
        Dataset root; ``image_2/``, ``image_3/``, ``disp_occ_0/``, ``disp_noc_0/`` are created.
    index : int
        Frame number, 0..999999.
    left, right : (H, W, 3) or (H, W) uint8 array
        Images, RGB order.
    disp_left : (H, W) float array
        Left ground truth in pixels; ``inf``/NaN exactly where ``mask_left == 0``; finite values
        in ``[0, 65535 / 256]``.
    mask_left : (H, W) uint8 array
        255 visible in both views, 128 occluded, 0 no ground truth.
    obj_map : (H, W) uint8 array, optional
        0 background, 1..255 object ids; written to ``obj_map/``.
    calib : str, optional
        Text of ``calib_cam_to_cam/NNNNNN.txt`` (:func:`format_kitti_calib`).
    fsync : bool, default True
        ``fsync`` each file before renaming it into place.
    image_deflate : {"isal", "libdeflate", "zlib", "stored"}, optional
        The deflate of the images' PNGs (``image_2``, ``image_3``;
        :func:`~matcher.io.png.encode_png`); default :func:`~matcher.io.png.deflate_for` each.
        The disparities and ``obj_map`` keep theirs.

    Returns
    -------
    list of pathlib.Path
        ``image_2``, ``image_3``, ``disp_occ_0``, ``disp_noc_0``, [``obj_map``,
        ``calib_cam_to_cam``] files, in that order.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> from matcher.io import load_kitti_2015
    >>> img = np.zeros((1, 3), np.uint8)
    >>> d = np.array([[2.5, 4.0, np.inf]])
    >>> mask = np.array([[255, 128, 0]], np.uint8)
    >>> with tempfile.TemporaryDirectory() as root:
    ...     _ = write_kitti(root, 3, left=img, right=img, disp_left=d, mask_left=mask)
    ...     s = load_kitti_2015(root, 3, occ=False)
    >>> s.disp_left.tolist(), s.mask_left.tolist()
    ([[2.5, inf, inf]], [[255, 128, 0]])
    """
    if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)) or not 0 <= index <= 999999:
        raise ValueError(f"index: expected an integer in [0, 999999], got {index!r}")
    if image_deflate is not None:
        check_deflate(image_deflate, "image_deflate")
    left, right = check_stereo_images(left, right)
    shape = left.shape[:2]
    mask_left = check_occlusion_mask(mask_left, "mask_left", shape=shape)
    disp = check_ground_truth(disp_left, "disp_left", shape=shape, mask=mask_left)
    occ = encode_kitti_disparity(disp, name="disp_left")
    noc = np.where(mask_left == 255, occ, np.uint16(0))

    root = Path(out_root)
    name = f"{int(index):06d}_10.png"
    files = {
        root / "image_2" / name: encode_png(left, deflate=image_deflate),
        root / "image_3" / name: encode_png(right, deflate=image_deflate),
        root / "disp_occ_0" / name: encode_png(occ),
        root / "disp_noc_0" / name: encode_png(noc),
    }
    if obj_map is not None:
        if not isinstance(obj_map, np.ndarray) or obj_map.dtype != np.uint8 or obj_map.shape != shape:
            got = f"{obj_map.dtype} {obj_map.shape}" if isinstance(obj_map, np.ndarray) else type(obj_map).__name__
            raise ValueError(f"obj_map: expected a uint8 array of shape {shape}, got {got}")
        files[root / "obj_map" / name] = encode_png(obj_map)
    if calib is not None:
        parse_kitti_calib(calib)  # refuse a malformed text before writing
        files[root / "calib_cam_to_cam" / f"{int(index):06d}.txt"] = calib.encode("ascii")
    for path in files:
        path.parent.mkdir(parents=True, exist_ok=True)
    return write_all_atomic(files, fsync=fsync)
