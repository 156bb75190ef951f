"""Disparity error metrics: PoBMP and RMS (the seed paper), plus Middlebury and KITTI measures.

Definitions (``d_C`` the estimate, ``d_T`` the ground truth, ``S`` the evaluated pixels, ``N = |S|``):

* **Evaluated set** ``S``: pixels whose ground truth is finite (``inf``/NaN mean "no ground
  truth" and are excluded), inside ``mask`` if given, and inside the chosen ``region``:

  - ``"all"``: every pixel with ground truth (where ``occlusion_mask`` is given, pixels coded
    0 = "no ground truth" are excluded too);
  - ``"nonocc"``: only pixels with ``occlusion_mask == 255`` (visible in both views; Middlebury's
    ``mask0nocc.png`` convention, 128 = occluded, 0 = no ground truth).

* **Invalid estimates**: non-finite ``d_C`` (``inf``, ``-inf``, NaN) inside ``S``. They count as
  BAD in every percentage (PoBMP, ``bad_*``, D1) and are left out of the error magnitudes
  (RMS, avgerr), whose denominator is the number of valid estimates ``N_v``.
* ``pobmp = 100 / N * #{(x, y) in S : |d_C - d_T| > delta or d_C invalid}`` (paper eq. for PoBMP,
  ``delta = 3`` as in the paper).
* ``rms = sqrt(1 / N_v * sum over valid (d_C - d_T)^2)`` (paper eq. for RMS; the paper's ``N``
  becomes ``N_v`` because an invalid estimate has no finite error). NaN when ``N_v = 0``.
* ``avgerr = 1 / N_v * sum over valid |d_C - d_T|`` (Middlebury SDK). NaN when ``N_v = 0``.
* ``bad_t`` for t in 0.5, 1, 2, 4: as PoBMP with threshold t (Middlebury SDK ``bad0.5`` ...).
* ``d1``: percentage with ``|err| > 3 px and |err| > 0.05 * d_T``, invalid counted bad (KITTI's
  outlier test, but not the devkit's D1: the devkit fills holes first; see :func:`kitti_2015`).
* ``invalid``: ``100 * #invalid / N``.

Thresholds are strict (``>``), as in the paper and both SDKs. Percentages are in [0, 100].

References
----------
"Improving Census Transform by High-Pass with Haar Wavelet Transform and Edge Detection",
Sensors 20(9), 2537 (2020), doi:10.3390/s20092537, section 4 (PoBMP, RMS).
Scharstein, D. and Szeliski, R., "A Taxonomy and Evaluation of Dense Two-Frame Stereo
Correspondence Algorithms", IJCV 47 (2002).
Menze, M. and Geiger, A., "Object Scene Flow for Autonomous Vehicles", CVPR 2015 (D1).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np

from matcher._validation import check_disparity_map, check_occlusion_mask, check_positive

__all__ = [
    "REGIONS",
    "Region",
    "Metrics",
    "evaluate",
    "pobmp",
    "rms",
]

Region = Literal["all", "nonocc"]
#: The regions every metric evaluates (see the module docstring).
REGIONS: tuple[str, ...] = get_args(Region)


@dataclass(frozen=True)
class Metrics:
    """Error measures of a disparity map against ground truth (see the module docstring).

    Attributes
    ----------
    pobmp : float
        Percentage of bad matching pixels, ``|err| > delta`` or invalid.
    rms : float
        Root-mean-square error over valid estimates (pixels); NaN if none is valid.
    avgerr : float
        Mean absolute error over valid estimates (pixels); NaN if none is valid.
    bad_0_5, bad_1, bad_2, bad_4 : float
        Percentage with ``|err|`` above 0.5, 1, 2, 4 px, invalid counted bad.
    d1 : float
        KITTI D1: percentage with ``|err| > 3`` and ``|err| > 5 %`` of the ground truth, invalid
        counted bad.
    invalid : float
        Percentage of evaluated pixels with a non-finite estimate.
    n_pixels : int
        Number of evaluated pixels ``N``.
    delta : float
        PoBMP threshold used.
    region : str
        ``"all"`` or ``"nonocc"``.
    """

    pobmp: float
    rms: float
    avgerr: float
    bad_0_5: float
    bad_1: float
    bad_2: float
    bad_4: float
    d1: float
    invalid: float
    n_pixels: int
    delta: float
    region: str


def _selection(
    disparity: object,
    gt: object,
    mask: object,
    region: object,
    occlusion_mask: object,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate and return ``(estimate, ground truth, valid-estimate flag)`` over the set S."""
    gt = check_disparity_map(gt, "gt")
    est = check_disparity_map(disparity, "disparity", shape=gt.shape, allow_integer=True)
    if region not in REGIONS:
        raise ValueError(f"region: expected one of {REGIONS}, got {region!r}")
    keep = np.isfinite(gt)
    if mask is not None:
        if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_:
            got = f"dtype {mask.dtype}" if isinstance(mask, np.ndarray) else type(mask).__name__
            raise TypeError(f"mask: expected a bool array (True = evaluate), got {got}; use mask.astype(bool)")
        if mask.shape != gt.shape:
            raise ValueError(f"mask: expected shape {gt.shape}, got {mask.shape}")
        keep &= mask
    if occlusion_mask is not None:
        occlusion_mask = check_occlusion_mask(occlusion_mask, "occlusion_mask", shape=gt.shape)
        keep &= occlusion_mask == 255 if region == "nonocc" else occlusion_mask != 0
    elif region == "nonocc":
        raise ValueError(
            "occlusion_mask: region='nonocc' needs the occlusion mask (255 = visible in both "
            "views, e.g. mask0nocc.png); pass occlusion_mask= or use region='all'"
        )
    if not keep.any():
        raise ValueError(
            "gt: no pixel to evaluate (no finite ground truth inside mask/region); "
            "check that the ground truth uses inf (not 0) only for unknown pixels"
        )
    e = est[keep].astype(np.float64)
    t = gt[keep].astype(np.float64)
    return e, t, np.isfinite(e)


def _bad(err: np.ndarray, valid: np.ndarray, threshold: float) -> float:
    n = valid.size
    return 100.0 * (int((err > threshold).sum()) + (n - err.size)) / n


def evaluate(
    disparity: np.ndarray,
    gt: np.ndarray,
    *,
    mask: np.ndarray | None = None,
    delta: float = 3.0,
    region: Region = "all",
    occlusion_mask: np.ndarray | None = None,
) -> Metrics:
    """Compare an estimated disparity map with ground truth.

    Parameters
    ----------
    disparity : (H, W) float or integer array
        Estimate in pixels; ``inf``/NaN mark pixels without an estimate (counted bad).
    gt : (H, W) float32 or float64 array
        Ground truth in pixels; ``inf``/NaN mark pixels without ground truth (excluded).
        Integer arrays are refused: decode file codes first (:func:`matcher.io.read_disparity`).
    mask : (H, W) bool array, optional
        Extra restriction, True = evaluate.
    delta : float, default 3.0
        PoBMP threshold in pixels (> 0); 3 in the paper.
    region : {"all", "nonocc"}, default "all"
        Pixels with ground truth, or only the non-occluded ones (needs ``occlusion_mask``).
    occlusion_mask : (H, W) uint8 array, optional
        Codes 255 (visible in both views), 128 (occluded), 0 (no ground truth).

    Returns
    -------
    Metrics
        All measures (see the module docstring for the definitions).

    Raises
    ------
    TypeError
        Wrong dtypes.
    ValueError
        Shape mismatch, ``delta <= 0``, unknown region, unknown mask codes, ``"nonocc"`` without
        a mask, or no pixel left to evaluate.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.array([[10.0, 10.0, 10.0, np.inf]])
    >>> est = np.array([[10.0, 14.0, np.inf, 0.0]])
    >>> m = evaluate(est, gt)
    >>> round(m.pobmp, 2), m.rms, m.invalid, m.n_pixels
    (66.67, 2.8284271247461903, 33.333333333333336, 3)
    """
    delta = check_positive(delta, "delta")
    e, t, valid = _selection(disparity, gt, mask, region, occlusion_mask)
    err = np.abs(e[valid] - t[valid])
    n = e.size
    n_valid = err.size
    if n_valid:
        rms_value = float(np.sqrt(np.mean(err * err)))
        avgerr = float(err.mean())
    else:
        rms_value = avgerr = float("nan")
    d1_bad = int(((err > 3.0) & (err > 0.05 * t[valid])).sum()) + (n - n_valid)
    return Metrics(
        pobmp=_bad(err, valid, delta),
        rms=rms_value,
        avgerr=avgerr,
        bad_0_5=_bad(err, valid, 0.5),
        bad_1=_bad(err, valid, 1.0),
        bad_2=_bad(err, valid, 2.0),
        bad_4=_bad(err, valid, 4.0),
        d1=100.0 * d1_bad / n,
        invalid=100.0 * (n - n_valid) / n,
        n_pixels=int(n),
        delta=delta,
        region=str(region),
    )


def pobmp(
    disparity: np.ndarray,
    gt: np.ndarray,
    *,
    delta: float = 3.0,
    mask: np.ndarray | None = None,
    region: Region = "all",
    occlusion_mask: np.ndarray | None = None,
) -> float:
    """Percentage of bad matching pixels, ``|d_C - d_T| > delta``, invalid estimates counted bad.

    Same parameters as :func:`evaluate`.

    Examples
    --------
    >>> import numpy as np
    >>> pobmp(np.array([[1.0, 5.0]]), np.array([[1.0, 1.0]]))
    50.0
    """
    delta = check_positive(delta, "delta")
    e, t, valid = _selection(disparity, gt, mask, region, occlusion_mask)
    return _bad(np.abs(e[valid] - t[valid]), valid, delta)


def rms(
    disparity: np.ndarray,
    gt: np.ndarray,
    *,
    mask: np.ndarray | None = None,
    region: Region = "all",
    occlusion_mask: np.ndarray | None = None,
) -> float:
    """Root-mean-square disparity error over the valid estimates (NaN if there are none).

    Same parameters as :func:`evaluate`.

    Examples
    --------
    >>> import numpy as np
    >>> rms(np.array([[1.0, 5.0, np.nan]]), np.array([[4.0, 1.0, 2.0]]))
    3.5355339059327378
    """
    e, t, valid = _selection(disparity, gt, mask, region, occlusion_mask)
    err = e[valid] - t[valid]
    return float(np.sqrt(np.mean(err * err))) if err.size else float("nan")
