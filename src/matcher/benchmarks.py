"""Disparity metrics as each benchmark's own evaluation code computes them, holes included.

Each function reproduces one benchmark, so that its figures can be put beside that benchmark's
tables: :func:`middlebury_v3` (the MiddEval3 SDK's ``evaldisp``), :func:`kitti_2015` (the KITTI
2015 devkit's D1, after :func:`kitti_interpolate_background` fills the holes as the devkit does)
and :func:`eth3d_two_view` (bad pixels over the estimated ones, and coverage). They differ from
:func:`matcher.metrics.evaluate` (and from each other) in how they count missing estimates;
docs/formats.md compares them, and tests/clients/ checks them against the real SDK and devkit.

References
----------
Scharstein, D. et al., "High-Resolution Stereo Datasets with Subpixel-Accurate Ground Truth",
GCPR 2014 (Middlebury v3).
Menze, M. and Geiger, A., "Object Scene Flow for Autonomous Vehicles", CVPR 2015 (D1).
Schöps, T. et al., "A Multi-View Stereo Benchmark with High-Resolution Images and Multi-Camera
Videos", CVPR 2017 (ETH3D).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from matcher._validation import check_disparity_map, check_occlusion_mask, check_positive
from matcher.metrics import REGIONS, Region

__all__ = [
    "Eth3dMetrics",
    "Kitti2015Metrics",
    "KittiD1",
    "MiddleburyV3Metrics",
    "eth3d_two_view",
    "kitti_2015",
    "kitti_interpolate_background",
    "middlebury_v3",
]

_THRESHOLDS = (0.5, 1.0, 2.0, 4.0)
_KITTI_REL = 0.05
_QUANTILES = (0.5, 0.9, 0.95, 0.99)


@dataclass(frozen=True)
class MiddleburyV3Metrics:
    """Middlebury v3 (MiddEval3 SDK 1.6 ``evaldisp``) measures of one disparity map.

    Attributes
    ----------
    bad_0_5, bad_1, bad_2, bad_4 : float
        evaldisp's ``bad``: percentage of evaluated pixels with a valid estimate whose error
        exceeds 0.5, 1, 2, 4 px (holes are not in it; the denominator is every evaluated pixel).
    total_bad_0_5, total_bad_1, total_bad_2, total_bad_4 : float
        evaldisp's ``totbad``: ``bad + invalid``.
    invalid : float
        Percentage of evaluated pixels without a valid estimate (``inf``, NaN, or above
        ``1000 * maxdisp``).
    avgerr : float
        Mean absolute error over the valid estimates (evaldisp's ``avgErr`` since 10/2014).
    rms : float
        Root-mean-square error over the valid estimates (the same convention as ``avgerr``).
    a50, a90, a95, a99 : float
        Error quantiles (px) over the valid estimates (numpy's linear interpolation).
    mask : float
        evaldisp's ``mask`` column: evaluated pixels in percent of the image.
    n_pixels : int
        Evaluated pixels (finite ground truth, and ``occlusion_mask == 255`` for ``"nonocc"``).
    region : str
    """

    bad_0_5: float
    bad_1: float
    bad_2: float
    bad_4: float
    total_bad_0_5: float
    total_bad_1: float
    total_bad_2: float
    total_bad_4: float
    invalid: float
    avgerr: float
    rms: float
    a50: float
    a90: float
    a95: float
    a99: float
    mask: float
    n_pixels: int
    region: str


def _benchmark_region(gt: np.ndarray, region: object, occlusion_mask: object) -> np.ndarray:
    if region not in REGIONS:
        raise ValueError(f"region: expected one of {REGIONS}, got {region!r}")
    keep = np.isfinite(gt)
    if occlusion_mask is not None:
        occ = check_occlusion_mask(occlusion_mask, "occlusion_mask", shape=gt.shape)
        if region == "nonocc":
            keep &= occ == 255
    elif region == "nonocc":
        raise ValueError("occlusion_mask: region='nonocc' needs the occlusion mask (255 = visible "
                         "in both views, e.g. mask0nocc.png); pass occlusion_mask= or use region='all'")
    if not keep.any():
        raise ValueError("gt: no pixel to evaluate (no finite ground truth in the region)")
    return keep


def _error_stats(err: np.ndarray) -> tuple[float, float, list[float]]:
    """avgerr, rms and the quantiles of ``err`` (float64), NaN when empty."""
    if not err.size:
        return math.nan, math.nan, [math.nan] * len(_QUANTILES)
    return (float(err.mean()), float(np.sqrt(np.mean(err * err))),
            [float(q) for q in np.quantile(err, _QUANTILES)])


def middlebury_v3(
    disparity: np.ndarray,
    gt: np.ndarray,
    *,
    occlusion_mask: np.ndarray | None = None,
    region: Region = "nonocc",
    maxdisp: int | None = None,
    rounddisp: bool = False,
) -> MiddleburyV3Metrics:
    """Score a disparity map as the MiddEval3 SDK's ``evaldisp`` does (same-size ground truth).

    As ``runeval`` calls it: ``evaldisp disp0X.pfm disp0GT.pfm thresh ndisp isint
    mask0nocc.png`` (``region="nonocc"``); without the mask (``region="all"``) every pixel with
    finite ground truth counts. An estimate is *valid* unless it is ``inf``, NaN or above
    ``1000 * maxdisp``; valid estimates are clipped to ``[0, maxdisp]`` (and rounded when
    ``rounddisp``, calib.txt's ``isint=1``) before the error is taken.

    Parameters
    ----------
    disparity : (H, W) float array
        Estimate (same size as ``gt``).
    gt : (H, W) float array
        Ground truth, ``inf`` = unknown.
    occlusion_mask : (H, W) uint8 array, optional
        ``mask0nocc.png``; needed for ``region="nonocc"``.
    region : {"nonocc", "all"}
    maxdisp : int, optional
        calib.txt's ``ndisp``; default evaldisp's 99999.
    rounddisp : bool
        calib.txt's ``isint``.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.array([[10.0, 10.0, 10.0, np.inf]])
    >>> m = middlebury_v3(np.array([[10.2, 13.0, np.inf, 0.0]]), gt, region="all", maxdisp=64)
    >>> round(m.bad_2, 2), round(m.invalid, 2), round(m.total_bad_2, 2), round(m.avgerr, 4)
    (33.33, 33.33, 66.67, 1.6)
    """
    gt = check_disparity_map(gt, "gt")
    est = check_disparity_map(disparity, "disparity", shape=gt.shape, allow_integer=True)
    maxd = 99999.0 if maxdisp is None else check_positive(maxdisp, "maxdisp")
    keep = _benchmark_region(gt, region, occlusion_mask)
    d = est[keep].astype(np.float32)
    t = gt[keep].astype(np.float32)
    with np.errstate(invalid="ignore"):
        valid = (d != np.inf) & (d <= np.float32(maxd * 1000))
    d = np.clip(d[valid], np.float32(0), np.float32(maxd))
    if rounddisp:
        d = np.round(d)
    err = np.abs(d - t[valid]).astype(np.float64)
    n, n_valid = int(keep.sum()), int(valid.sum())
    bad = {th: 100.0 * int((err > th).sum()) / n for th in _THRESHOLDS}
    invalid = 100.0 * (n - n_valid) / n
    avgerr, rms_value, quantiles = _error_stats(err)
    return MiddleburyV3Metrics(
        *(bad[th] for th in _THRESHOLDS), *(bad[th] + invalid for th in _THRESHOLDS),
        invalid=invalid, avgerr=avgerr, rms=rms_value, a50=quantiles[0], a90=quantiles[1],
        a95=quantiles[2], a99=quantiles[3], mask=100.0 * n / gt.size, n_pixels=n, region=str(region))


def kitti_interpolate_background(disparity: np.ndarray) -> np.ndarray:
    """Fill the holes of an estimate as the KITTI 2015 devkit does before scoring it.

    ``DisparityImage::interpolateBackground`` (io_disp.h): per row, a run of invalid pixels
    between two valid ones takes the smaller (background) of the two; runs touching the left or
    right border take the nearest valid value; then per column, rows above the first and below
    the last valid row take its value. Invalid means ``inf``/NaN or negative (the devkit's
    ``d < 0``); rows left without any value stay invalid (-1).

    Returns
    -------
    (H, W) float32 array
        -1 where still invalid.

    Examples
    --------
    >>> import numpy as np
    >>> kitti_interpolate_background(np.array([[np.inf, 5, np.inf, np.inf, 2, np.inf]])).tolist()
    [[5.0, 5.0, 2.0, 2.0, 2.0, 2.0]]
    """
    d = check_disparity_map(disparity, "disparity", allow_integer=True).astype(np.float32)
    with np.errstate(invalid="ignore"):
        valid = np.isfinite(d) & (d >= 0)
    d = np.where(valid, d, np.float32(-1))
    h, w = d.shape
    cols = np.arange(w)
    prev = np.maximum.accumulate(np.where(valid, cols, -1), axis=1)
    nxt = np.minimum.accumulate(np.where(valid, cols, w)[:, ::-1], axis=1)[:, ::-1]
    rows = np.arange(h)[:, None]
    has_prev, has_next = prev >= 0, nxt < w
    left = d[rows, np.clip(prev, 0, w - 1)]
    right = d[rows, np.clip(nxt, 0, w - 1)]
    out = np.where(has_prev & has_next, np.minimum(left, right),
                   np.where(has_prev, left, np.where(has_next, right, np.float32(-1))))
    out = np.where(valid, d, out).astype(np.float32)
    full = valid.any(axis=1)
    if full.any():
        first, last = int(np.argmax(full)), h - 1 - int(np.argmax(full[::-1]))
        out[:first] = out[first]
        out[last + 1:] = out[last]
    return out


@dataclass(frozen=True)
class KittiD1:
    """KITTI 2015 D1 outlier percentages in one ground-truth region (``noc`` or ``occ``).

    Attributes
    ----------
    bg, fg, all : float
        Outliers (``|err| > 3 px`` and ``|err| / d_gt > 5 %``) in percent of the ground-truth
        pixels of the background (``obj_map == 0``), foreground and all, after the holes of the
        estimate were interpolated (:func:`kitti_interpolate_background`). The devkit's
        ``D1-bg``, ``D1-fg``, ``D1-all``. NaN where the region is empty.
    bg_est, fg_est, all_est : float
        The same over the pixels the estimate itself covers (before interpolation).
    density : float
        Estimated pixels in percent of the ground-truth pixels.
    n_pixels : int
    """

    bg: float
    fg: float
    all: float
    bg_est: float
    fg_est: float
    all_est: float
    density: float
    n_pixels: int


@dataclass(frozen=True)
class Kitti2015Metrics:
    """KITTI 2015 stereo measures: ``occ`` (all ground truth) and ``noc`` (non-occluded)."""

    occ: KittiD1
    noc: KittiD1 | None


def _pct(num: int, den: int) -> float:
    return 100.0 * num / den if den else math.nan


def _d1_region(outlier: np.ndarray, estimated: np.ndarray, fg: np.ndarray, keep: np.ndarray) -> KittiD1:
    def count(sel: np.ndarray) -> tuple[float, float]:
        return (_pct(int((outlier & sel).sum()), int(sel.sum())),
                _pct(int((outlier & sel & estimated).sum()), int((sel & estimated).sum())))

    bg, bg_est = count(keep & ~fg)
    fgv, fg_est = count(keep & fg)
    al, al_est = count(keep)
    n = int(keep.sum())
    return KittiD1(bg, fgv, al, bg_est, fg_est, al_est, _pct(int((keep & estimated).sum()), n), n)


def kitti_2015(
    disparity: np.ndarray,
    gt: np.ndarray,
    *,
    occlusion_mask: np.ndarray | None = None,
    obj_map: np.ndarray | None = None,
) -> Kitti2015Metrics:
    """Score a disparity map as the KITTI 2015 devkit's ``evaluate_scene_flow`` does (D1).

    Holes (``inf``/NaN/negative) are first filled by :func:`kitti_interpolate_background`; a
    pixel is an outlier when ``|d - d_gt| > 3`` and ``|d - d_gt| / |d_gt| > 0.05`` (float32, as
    the devkit computes). The devkit reads the estimate from a 16-bit PNG, i.e. quantized to
    1/256 px: pass ``read_disparity(png)`` (or a map rounded the same way) to get its numbers
    exactly.

    Parameters
    ----------
    disparity : (H, W) float array
    gt : (H, W) float array
        All ground truth (``disp_occ_0``), ``inf`` = none.
    occlusion_mask : (H, W) uint8 array, optional
        255 = non-occluded (``disp_noc_0`` valid); gives the ``noc`` region.
    obj_map : (H, W) integer array, optional
        0 background, > 0 foreground (``obj_map/``); without it every pixel is background.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.array([[10.0, 10.0, 100.0, 100.0]])
    >>> m = kitti_2015(np.array([[14.0, np.inf, 104.0, 100.0]]), gt)
    >>> m.occ.all, m.occ.all_est, m.occ.density
    (50.0, 33.333333333333336, 75.0)
    """
    gt = check_disparity_map(gt, "gt")
    est = check_disparity_map(disparity, "disparity", shape=gt.shape, allow_integer=True)
    with np.errstate(invalid="ignore"):
        estimated = np.isfinite(est) & (est >= 0)
    ipol = kitti_interpolate_background(est)
    g = np.where(np.isfinite(gt), gt, 0).astype(np.float32)
    err = np.abs(g - ipol)
    with np.errstate(divide="ignore", invalid="ignore"):
        outlier = (err > 3.0) & ((err / np.abs(g)).astype(np.float64) > _KITTI_REL)
    if obj_map is None:
        fg = np.zeros(gt.shape, bool)
    else:
        obj = np.asarray(obj_map)
        if obj.shape != gt.shape or not np.issubdtype(obj.dtype, np.integer):
            raise ValueError(f"obj_map: expected an integer array of shape {gt.shape}, got "
                             f"{obj.dtype} {obj.shape}")
        fg = obj != 0
    occ_keep = np.isfinite(gt)
    if not occ_keep.any():
        raise ValueError("gt: no pixel to evaluate (no finite ground truth)")
    noc = None
    if occlusion_mask is not None:
        occ = check_occlusion_mask(occlusion_mask, "occlusion_mask", shape=gt.shape)
        noc = _d1_region(outlier, estimated, fg, occ_keep & (occ == 255))
    return Kitti2015Metrics(_d1_region(outlier, estimated, fg, occ_keep), noc)


@dataclass(frozen=True)
class Eth3dMetrics:
    """ETH3D two-view measures: errors over the pixels the estimate covers, and the coverage.

    Attributes
    ----------
    bad_0_5, bad_1, bad_2, bad_4 : float
        Percentage of *estimated* evaluated pixels with an error above 0.5, 1, 2, 4 px.
    avgerr, rms : float
        Mean absolute and root-mean-square error over the estimated pixels.
    a50, a90, a95, a99 : float
        Error quantiles over the estimated pixels.
    coverage : float
        Estimated pixels in percent of the evaluated pixels.
    n_pixels : int
    region : str
    """

    bad_0_5: float
    bad_1: float
    bad_2: float
    bad_4: float
    avgerr: float
    rms: float
    a50: float
    a90: float
    a95: float
    a99: float
    coverage: float
    n_pixels: int
    region: str


def eth3d_two_view(
    disparity: np.ndarray,
    gt: np.ndarray,
    *,
    occlusion_mask: np.ndarray | None = None,
    region: Region = "nonocc",
) -> Eth3dMetrics:
    """Score a disparity map in the ETH3D two-view convention (holes lower the coverage only).

    Examples
    --------
    >>> import numpy as np
    >>> m = eth3d_two_view(np.array([[10.0, 13.0, np.inf]]), np.array([[10.0, 10.0, 10.0]]), region="all")
    >>> m.bad_2, round(m.coverage, 2)
    (50.0, 66.67)
    """
    gt = check_disparity_map(gt, "gt")
    est = check_disparity_map(disparity, "disparity", shape=gt.shape, allow_integer=True)
    keep = _benchmark_region(gt, region, occlusion_mask)
    e, t = est[keep].astype(np.float64), gt[keep].astype(np.float64)
    estimated = np.isfinite(e)
    err = np.abs(e[estimated] - t[estimated])
    avgerr, rms_value, quantiles = _error_stats(err)
    bad = [_pct(int((err > th).sum()), err.size) for th in _THRESHOLDS]
    return Eth3dMetrics(*bad, avgerr=avgerr, rms=rms_value, a50=quantiles[0], a90=quantiles[1],
                        a95=quantiles[2], a99=quantiles[3], coverage=_pct(err.size, e.size),
                        n_pixels=int(e.size), region=str(region))
