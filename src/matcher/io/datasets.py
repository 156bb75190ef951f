"""Loaders for real stereo datasets: Middlebury 2005/2006, Middlebury 2014, KITTI 2015.

Each returns a :class:`StereoSample` whose disparities are float32 pixels with ``inf`` where there
is no ground truth (see ``docs/formats.md`` for the file layouts).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from matcher._validation import check_positive
from matcher.io.calib import read_calib
from matcher.io.images import KITTI_DIVISOR, read_disparity, read_image

__all__ = [
    "StereoSample",
    "infer_middlebury_2005_divisor",
    "load_kitti_2015",
    "load_middlebury_2005",
    "load_middlebury_2014",
]

_SIZE_DIVISORS = (("third", 3.0), ("half", 2.0), ("full", 1.0))


@dataclass(frozen=True, eq=False)
class StereoSample:
    """A rectified stereo pair with ground truth.

    Attributes
    ----------
    left, right : (H, W, 3) uint8 array
        RGB images (``(H, W)`` for grey files).
    disp_left : (H, W) float32 array
        Left ground-truth disparity in pixels, ``inf`` where unknown.
    disp_right : (H, W) float32 array or None
        Right ground truth, when the dataset provides it.
    name : str
        Scene name or frame id.
    meta : dict
        Dataset-specific information (``dataset``, ``divisor``, ``calib``, paths ...).
    mask_left : (H, W) uint8 array or None
        Occlusion mask of the left view (255 visible in both, 128 occluded, 0 no ground truth),
        when the dataset provides one.
    """

    left: np.ndarray
    right: np.ndarray
    disp_left: np.ndarray
    disp_right: np.ndarray | None
    name: str
    meta: dict = field(default_factory=dict)
    mask_left: np.ndarray | None = None


def _require_dir(path: Path, what: str) -> None:
    if not path.is_dir():
        raise FileNotFoundError(f"{what}: {path} is not a directory")


def _check_pair(sample_dir: Path, left: np.ndarray, right: np.ndarray, *disps: np.ndarray | None) -> None:
    for array in (right, *disps):
        if array is not None and array.shape[:2] != left.shape[:2]:
            raise ValueError(
                f"{sample_dir}: image/disparity sizes differ: {left.shape[:2]} vs {array.shape[:2]}"
            )


def infer_middlebury_2005_divisor(scene_dir: str | os.PathLike[str]) -> float:
    """Infer the disparity divisor of a Middlebury 2005/2006 scene from its folder names.

    The nearest enclosing folder whose name contains ``third``, ``half`` or ``full``
    (case-insensitive, e.g. ``third/``, ``ThirdSize/``, ``HalfSize/``) gives 3, 2 or 1.

    Raises
    ------
    ValueError
        If no folder name says; pass ``divisor`` explicitly then.

    Examples
    --------
    >>> infer_middlebury_2005_divisor("data/middlebury/third/Moebius")
    3.0
    """
    path = Path(scene_dir)
    for part in reversed(path.resolve().parts if path.exists() else path.parts):
        lower = part.lower()
        for word, divisor in _SIZE_DIVISORS:
            if word in lower:
                return divisor
    raise ValueError(
        f"divisor: cannot infer the size variant of {path} (no folder named third/half/full); "
        "pass divisor=3 (third size), 2 (half) or 1 (full)"
    )


def load_middlebury_2005(scene_dir: str | os.PathLike[str], *, divisor: float | None = None) -> StereoSample:
    """Load a Middlebury 2005/2006 scene (``view1.png``, ``view5.png``, ``disp1.png``, ``disp5.png``).

    Parameters
    ----------
    scene_dir : str or path-like
        Folder of one scene, e.g. ``.../middlebury/third/Moebius``.
    divisor : float, optional
        PNG codes per pixel: 3 for the third size, 2 for half, 1 for full. When None it is
        inferred from the folder names (:func:`infer_middlebury_2005_divisor`).

    Returns
    -------
    StereoSample
        ``disp_left``/``disp_right`` are ``code / divisor``, ``inf`` where the code is 0
        (unknown); ``disp_right`` is None when ``disp5.png`` is absent. ``meta`` holds
        ``dataset="middlebury2005"``, ``divisor`` and ``scene_dir``.

    Examples
    --------
    >>> import tempfile, pathlib, cv2, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     s = pathlib.Path(d, "third", "Toy"); s.mkdir(parents=True)
    ...     for n in ("view1", "view5"): _ = cv2.imwrite(str(s / f"{n}.png"), np.zeros((2, 3, 3), np.uint8))
    ...     _ = cv2.imwrite(str(s / "disp1.png"), np.array([[0, 3, 6], [9, 3, 0]], np.uint8))
    ...     load_middlebury_2005(s).disp_left[0].tolist()
    [inf, 1.0, 2.0]
    """
    scene_dir = Path(scene_dir)
    _require_dir(scene_dir, "scene_dir")
    divisor = infer_middlebury_2005_divisor(scene_dir) if divisor is None else check_positive(divisor, "divisor")
    left = read_image(scene_dir / "view1.png")
    right = read_image(scene_dir / "view5.png")
    disp_left = read_disparity(scene_dir / "disp1.png", divisor=divisor)
    disp5 = scene_dir / "disp5.png"
    disp_right = read_disparity(disp5, divisor=divisor) if disp5.is_file() else None
    _check_pair(scene_dir, left, right, disp_left, disp_right)
    meta = {"dataset": "middlebury2005", "divisor": divisor, "scene_dir": str(scene_dir)}
    return StereoSample(left, right, disp_left, disp_right, scene_dir.name, meta)


def load_middlebury_2014(scene_dir: str | os.PathLike[str]) -> StereoSample:
    """Load a Middlebury 2014 scene (also the layout :mod:`synth` writes).

    Reads ``im0.png``, ``im1.png``, ``disp0.pfm``, ``calib.txt`` and, when present,
    ``disp1.pfm`` and ``mask0nocc.png``.

    Returns
    -------
    StereoSample
        Disparities as stored (``inf`` where there is no ground truth); ``meta["calib"]`` is the
        parsed ``calib.txt`` (:func:`matcher.io.read_calib`); ``mask_left`` the occlusion mask
        or None.

    Examples
    --------
    >>> import tempfile, pathlib, cv2, numpy as np
    >>> from matcher.io import write_pfm, format_calib
    >>> with tempfile.TemporaryDirectory() as d:
    ...     s = pathlib.Path(d)
    ...     for n in ("im0", "im1"): _ = cv2.imwrite(str(s / f"{n}.png"), np.zeros((2, 3, 3), np.uint8))
    ...     _ = write_pfm(s / "disp0.pfm", np.array([[1, 2, np.inf], [1, 2, 3]]))
    ...     _ = (s / "calib.txt").write_text(format_calib({"cam0": np.eye(3), "ndisp": 8}))
    ...     load_middlebury_2014(s).meta["calib"]["ndisp"]
    8
    """
    scene_dir = Path(scene_dir)
    _require_dir(scene_dir, "scene_dir")
    left = read_image(scene_dir / "im0.png")
    right = read_image(scene_dir / "im1.png")
    disp_left = read_disparity(scene_dir / "disp0.pfm")
    disp1 = scene_dir / "disp1.pfm"
    disp_right = read_disparity(disp1) if disp1.is_file() else None
    mask_path = scene_dir / "mask0nocc.png"
    mask = read_image(mask_path) if mask_path.is_file() else None
    if mask is not None and mask.ndim != 2:
        raise ValueError(f"{mask_path}: expected a grey mask, got shape {mask.shape}")
    _check_pair(scene_dir, left, right, disp_left, disp_right, mask)
    calib = read_calib(scene_dir / "calib.txt")
    meta = {"dataset": "middlebury2014", "calib": calib, "scene_dir": str(scene_dir)}
    return StereoSample(left, right, disp_left, disp_right, scene_dir.name, meta, mask)


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
    _require_dir(root, "root")
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
    _check_pair(root, left, right, disp_left, mask)
    meta = {"dataset": "kitti2015", "occ": occ, "root": str(root), "index": int(index)}
    return StereoSample(left, right, disp_left, None, f"{int(index):06d}", meta, mask)
