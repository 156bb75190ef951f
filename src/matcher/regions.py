"""Evaluation regions of a rendered pair, from its exact ground truth, and region-wise scores.

The five regions (``docs/formats.md``, *Validation regions*), each a subset of the pixels with
ground truth (finite disparity and a non-zero occlusion mask):

- ``all``: every pixel with ground truth;
- ``nonocc``: visible in both views (occlusion mask 255);
- ``occluded``: occluded in, or outside, the right view (mask 128);
- ``textureless``: where the **noise-free** left image has a local gradient energy below
  :data:`TEXTURELESS_ENERGY`: the mean of ``gx^2 + gy^2`` over a
  :data:`TEXTURELESS_WINDOW` x :data:`TEXTURELESS_WINDOW` box, with ``gx``, ``gy`` the central
  differences (half the difference of the two neighbours) of the BT.601 grey image in grey levels
  (0..255); the default threshold 4.0 is an RMS gradient of 2 grey levels per pixel;
- ``discontinuity``: within :data:`DISCONTINUITY_RADIUS` pixels (Euclidean) of a ground-truth
  depth edge: a pixel whose 4-neighbour's disparity differs by more than
  :data:`DISCONTINUITY_JUMP` pixels, or has no ground truth while it has.

Pure numpy and OpenCV: the renderer's side only supplies the arrays.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["REGIONS", "TEXTURELESS_ENERGY", "TEXTURELESS_WINDOW", "DISCONTINUITY_JUMP",
           "DISCONTINUITY_RADIUS", "THRESHOLDS", "SCORE_NAMES", "LR_TOLERANCE",
           "occlusion_from_disparities", "region_masks", "region_scores"]

REGIONS = ("all", "nonocc", "occluded", "textureless", "discontinuity")
#: Mean squared gradient (grey levels^2 per pixel^2) below which a pixel is textureless.
TEXTURELESS_ENERGY = 4.0
#: Side of the box the gradient energy is averaged over, pixels.
TEXTURELESS_WINDOW = 7
#: Disparity jump (pixels) between 4-neighbours that makes a depth edge.
DISCONTINUITY_JUMP = 1.0
#: Distance (pixels) from a depth edge within which a pixel is near a discontinuity.
DISCONTINUITY_RADIUS = 3
#: Bad-pixel thresholds of ``bad_0_5``, ``bad_1``, ``bad_2``, ``bad_4``.
THRESHOLDS = (0.5, 1.0, 2.0, 4.0)
SCORE_NAMES = ("bad_0_5", "bad_1", "bad_2", "bad_4", "avgerr", "rms", "a50", "a90", "a99",
               "coverage")
#: Largest difference (pixels) between a left ground-truth disparity and the right one at its
#: match for the left pixel to count as visible in both views.
LR_TOLERANCE = 1.0


def _grey(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim == 3:
        img = img.astype(np.float64) @ np.array([0.299, 0.587, 0.114])
    return img.astype(np.float64)


def gradient_energy(image: np.ndarray, *, window: int = TEXTURELESS_WINDOW) -> np.ndarray:
    """Box mean of the squared central-difference gradient of ``image``'s grey levels, (H, W)
    float64 (borders replicated)."""
    g = np.pad(_grey(image), 1, mode="edge")
    gx = (g[1:-1, 2:] - g[1:-1, :-2]) / 2.0
    gy = (g[2:, 1:-1] - g[:-2, 1:-1]) / 2.0
    return cv2.blur(gx * gx + gy * gy, (window, window), borderType=cv2.BORDER_REPLICATE)


def _depth_edges(gt: np.ndarray, has_gt: np.ndarray, jump: float) -> np.ndarray:
    edges = np.zeros(gt.shape, bool)
    g = np.where(has_gt, gt, 0.0).astype(np.float64)
    for axis in (0, 1):
        a = [slice(None)] * 2
        b = [slice(None)] * 2
        a[axis], b[axis] = slice(1, None), slice(None, -1)
        va, vb = has_gt[tuple(a)], has_gt[tuple(b)]
        step = (va & vb & (np.abs(g[tuple(a)] - g[tuple(b)]) > jump)) | (va != vb)
        edges[tuple(a)] |= step & va
        edges[tuple(b)] |= step & vb
    return edges


def occlusion_from_disparities(disp_left: np.ndarray, disp_right: np.ndarray | None = None, *,
                               tolerance: float = LR_TOLERANCE) -> np.ndarray:
    """The occlusion mask of a left view from ground truth: a left-right check.

    A left pixel ``(y, x)`` with ground truth ``d`` matches the right pixel
    ``(y, round(x - d))``; it is visible in both views (255) when that pixel lies in the right
    image and the right disparity there is within ``tolerance`` of ``d``, else occluded (128:
    hidden, outside the right view, or no right ground truth there to confirm it); 0 = no left
    ground truth. Without ``disp_right``, the right view's disparity is the left ground truth
    warped to it, the nearest surface (the largest disparity) winning at each right pixel.

    Parameters
    ----------
    disp_left : (H, W) float array
        Left ground truth, inf or NaN = unknown.
    disp_right : (H, W) float array, optional
        Right ground truth (a right pixel at ``x`` matches the left pixel at ``x + d``).
    tolerance : float
        See :data:`LR_TOLERANCE`.

    Returns
    -------
    (H, W) uint8 array
        255, 128 or 0 (``mask0nocc.png``'s codes).

    Examples
    --------
    >>> gt = np.array([[1.0, 1.0, 1.0, 1.0, 3.0, 3.0, np.inf]])  # a near object on the right
    >>> occlusion_from_disparities(gt).tolist()  # x=0 leaves the right view, it hides x=2, 3
    [[128, 255, 128, 128, 255, 255, 0]]
    """
    left = np.asarray(disp_left, np.float64)
    h, w = left.shape
    known = np.isfinite(left)
    xs = np.broadcast_to(np.arange(w), (h, w))
    target = np.rint(xs - np.where(known, left, 0.0)).astype(np.int64)
    inside = known & (target >= 0) & (target < w)
    rows = np.broadcast_to(np.arange(h)[:, None], (h, w))
    if disp_right is None:
        right = np.full((h, w), -np.inf)
        np.maximum.at(right, (rows[inside], target[inside]), left[inside])
    else:
        right = np.asarray(disp_right, np.float64)
    seen = np.full((h, w), np.nan)
    seen[inside] = right[rows[inside], target[inside]]
    visible = inside & np.isfinite(seen) & (np.abs(seen - left) <= tolerance)
    return np.where(visible, 255, np.where(known, 128, 0)).astype(np.uint8)


def region_masks(gt: np.ndarray, occlusion: np.ndarray, clean_left: np.ndarray, *,
                 textureless_energy: float = TEXTURELESS_ENERGY,
                 discontinuity_radius: int = DISCONTINUITY_RADIUS) -> dict[str, np.ndarray]:
    """The five regions of a pair as (H, W) bool masks, keyed by :data:`REGIONS`.

    Parameters
    ----------
    gt : (H, W) float array
        Ground-truth left disparity (inf or NaN = none).
    occlusion : (H, W) uint8 array
        255 visible in both views, 128 occluded, 0 no ground truth.
    clean_left : (H, W, 3) or (H, W) array
        The rendered left image **before** any photometric degradation.

    Examples
    --------
    >>> gt = np.full((12, 12), 2.0); gt[:, 6:] = 5.0
    >>> occ = np.full((12, 12), 255, np.uint8)
    >>> m = region_masks(gt, occ, np.zeros((12, 12), np.uint8))
    >>> int(m["all"].sum()), int(m["textureless"].sum()), m["discontinuity"][0].nonzero()[0].tolist()
    (144, 144, [2, 3, 4, 5, 6, 7, 8, 9])
    """
    gt = np.asarray(gt)
    has_gt = np.isfinite(gt) & (np.asarray(occlusion) != 0)
    edges = _depth_edges(gt, has_gt, DISCONTINUITY_JUMP)
    r = int(discontinuity_radius)
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    disc = (xx * xx + yy * yy <= r * r).astype(np.uint8)
    near = cv2.dilate(edges.astype(np.uint8), disc, borderType=cv2.BORDER_CONSTANT,
                      borderValue=0).astype(bool)
    return {
        "all": has_gt,
        "nonocc": has_gt & (occlusion == 255),
        "occluded": has_gt & (occlusion == 128),
        "textureless": has_gt & (gradient_energy(clean_left) < textureless_energy),
        "discontinuity": has_gt & near,
    }


def region_scores(estimate: np.ndarray | None, gt: np.ndarray,
                  region: np.ndarray) -> dict[str, float | None]:
    """Scores of ``estimate`` over one region (None where undefined, e.g. an empty region).

    ``bad_*`` and ``coverage`` are fractions of the region's pixels (which all have ground
    truth): a pixel without estimate (inf/NaN) counts as bad; ``avgerr``, ``rms`` and the
    quantiles ``a50``, ``a90``, ``a99`` of the absolute error are over the estimated pixels.
    ``estimate=None`` (the matcher failed) scores as no estimate anywhere.

    Examples
    --------
    >>> s = region_scores(np.array([[1.0, 3.0, np.inf]]), np.array([[1.0, 1.0, 1.0]]),
    ...                   np.array([[True, True, True]]))
    >>> s["bad_1"], s["avgerr"], round(s["coverage"], 3)
    (0.6666666666666666, 1.0, 0.667)
    """
    n = int(np.count_nonzero(region))
    out: dict[str, float | None] = dict.fromkeys(SCORE_NAMES)
    if n == 0:
        return out
    t = np.asarray(gt, np.float64)[region]
    if estimate is None:
        e = np.full(n, np.inf)
    else:
        e = np.asarray(estimate, np.float64)[region]
    ok = np.isfinite(e)
    err = np.abs(e[ok] - t[ok])
    for name, th in zip(SCORE_NAMES[:4], THRESHOLDS):
        out[name] = (n - int(np.count_nonzero(err <= th))) / n
    out["coverage"] = int(ok.sum()) / n
    if err.size:
        out["avgerr"] = float(err.mean())
        out["rms"] = float(math.sqrt(float(np.mean(err * err))))
        out["a50"], out["a90"], out["a99"] = (float(q) for q in np.quantile(err, (0.5, 0.9, 0.99)))
    return out
