"""The ``match`` API, the dispatcher at the top of matcher's graph: census (CT), sparse census
(SCT), the seed paper's CTHW, AWCT and AWSCT, and the OpenCV baselines (BM, SGBM).

CT and SCT run the fused census kernel of :func:`matcher.census.census_disparity`; CTHW and
AWCT/AWSCT are :func:`matcher.cthw.match_cthw` and :func:`matcher.adaptive.match_awct` /
``match_awsct`` with their defaults.
"""

from __future__ import annotations

import types

import cv2
import numpy as np

from matcher._validation import (
    check_bool,
    check_image,
    check_max_disparity,
    check_same_shape,
    check_window,
)
from matcher.adaptive import match_awct, match_awsct
from matcher.census import census_disparity
from matcher.cthw import match_cthw
from matcher.patterns import check_side, resolve_offsets
from matcher.result import MatchResult, census_ops

__all__ = ["METHODS", "match"]

#: Accepted values of ``match(method=...)``.
METHODS = ("ct", "sct", "cthw", "awct", "awsct", "bm", "sgbm")
_PAPER_METHODS = ("cthw", "awct", "awsct")


def _to_uint8(grey_l: np.ndarray, grey_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """uint8 views for OpenCV: uint8 unchanged; others scaled jointly from [min, max] to [0, 255]."""
    if grey_l.dtype == np.uint8 and grey_r.dtype == np.uint8:
        return grey_l, grey_r
    lo = min(float(grey_l.min()), float(grey_r.min()))
    hi = max(float(grey_l.max()), float(grey_r.max()))
    scale = 255.0 / (hi - lo) if hi > lo else 0.0

    def conv(g: np.ndarray) -> np.ndarray:
        return np.clip(np.floor((g.astype(np.float64) - lo) * scale + 0.5), 0, 255).astype(np.uint8)

    return conv(grey_l), conv(grey_r)


def _match_opencv(
    grey_l: np.ndarray,
    grey_r: np.ndarray,
    *,
    method: str,
    window: int,
    max_disparity: int,
    lr_tolerance: int | None,
    subpixel: bool,
) -> tuple[np.ndarray, dict[str, object]]:
    left, right = _to_uint8(grey_l, grey_r)
    num = -(-max_disparity // 16) * 16
    disp12 = -1 if lr_tolerance is None else int(lr_tolerance)
    if method == "bm":
        if window < 5:
            raise ValueError(
                f"window: expected an odd integer >= 5 for method='bm' (OpenCV StereoBM), got "
                f"{window}; use window=5 or a census method"
            )
        matcher = cv2.StereoBM_create(numDisparities=num, blockSize=window)
        matcher.setDisp12MaxDiff(disp12)
        params: dict[str, object] = {"numDisparities": num, "blockSize": window}
    else:
        p1, p2 = 8 * window * window, 32 * window * window
        matcher = cv2.StereoSGBM_create(
            minDisparity=0, numDisparities=num, blockSize=window, P1=p1, P2=p2,
            disp12MaxDiff=disp12,
        )
        params = {"numDisparities": num, "blockSize": window, "P1": p1, "P2": p2,
                  "mode": "MODE_SGBM"}
    params["disp12MaxDiff"] = disp12
    raw = matcher.compute(left, right)
    disp = raw.astype(np.float32) / np.float32(16.0)
    if not subpixel:
        disp = np.floor(disp + np.float32(0.5))
    disp[raw < 0] = np.inf
    return disp.astype(np.float32), params


def match(
    left: np.ndarray,
    right: np.ndarray,
    *,
    method: str = "ct",
    window: int = 9,
    max_disparity: int = 64,
    lr_check: bool = False,
    lr_tolerance: int = 1,
    subpixel: bool = False,
    aggregate: int | None = None,
) -> MatchResult:
    """Match a rectified stereo pair and return the left-view disparity.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) uint8, integer or float arrays
        Rectified views, same shape; RGB is converted to grey (BT.601).
    method : {"ct", "sct", "cthw", "awct", "awsct", "bm", "sgbm"}, default "ct"
        Dense census, sparse census (:func:`matcher.patterns.sparse_pattern`), the seed paper's
        census with Haar wavelet (:func:`matcher.cthw.match_cthw`), adaptive-window census
        and adaptive sparse census (:func:`matcher.adaptive.match_awct` / ``match_awsct``, with
        ``window`` as the largest window and every other option at its documented default;
        call those functions directly to set them), OpenCV
        ``StereoBM`` (``blockSize=window``, needs ``window >= 5``) or ``StereoSGBM``
        (``blockSize=window``, ``MODE_SGBM``, ``P1 = 8 window^2``, ``P2 = 32 window^2``).
        The OpenCV methods search ``numDisparities = 16 * ceil(max_disparity / 16)``; non-uint8
        input is scaled jointly from its [min, max] to uint8 for them.
    window : int, default 9
        Odd census window (or block) side, ``3 <= window <= min(H, W)``.
    max_disparity : int, default 64
        Number of candidates ``D``: disparities ``0 .. D - 1``; ``1 <= D < W``.
    lr_check : bool, default False
        Left-right consistency check; failures become ``inf`` (OpenCV: ``disp12MaxDiff``).
    lr_tolerance : int, default 1
        Largest accepted left-right difference in pixels.
    subpixel : bool, default False
        Parabola refinement (census); for OpenCV, keep its 1/16-pixel output (``False`` rounds
        it to integers).
    aggregate : int or None, default None
        Census only: box-sum the Hamming costs over ``aggregate x aggregate`` pixels before
        WTA; ``None`` uses per-pixel Hamming costs, as the paper does.

    Returns
    -------
    MatchResult

    Raises
    ------
    ValueError, TypeError
        Bad images (shapes differ, NaN, wrong dtype), even or out-of-range windows,
        ``max_disparity >= W``, unknown method, or options the method does not support.

    References
    ----------
    Zabih & Woodfill, ECCV 1994 (census); Liaw et al., Sensors 20(9):2537, 2020 (this
    toolkit's seed paper); Hirschmüller, TPAMI 30(2), 2008 (SGM).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (32, 48), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)  # left pixel x matches right pixel x - 3
    >>> res = match(left, right, window=5, max_disparity=8)
    >>> float(np.median(res.disparity[:, 8:-3])), res.ops.census_comparisons
    (3.0, 73728)
    """
    if method not in METHODS:
        raise ValueError(f"method: expected one of {METHODS}, got {method!r}")
    grey_l = check_image(left, "left")
    grey_r = check_image(right, "right")
    check_same_shape(grey_l, grey_r)
    window = check_side(check_window(window, "window", image_shape=grey_l.shape))
    max_disparity = check_max_disparity(max_disparity, grey_l.shape[1])
    lr_check = check_bool(lr_check, "lr_check")
    subpixel = check_bool(subpixel, "subpixel")
    if isinstance(lr_tolerance, bool) or not isinstance(lr_tolerance, (int, np.integer)):
        raise TypeError(f"lr_tolerance: expected an integer >= 0, got {lr_tolerance!r}")
    if lr_tolerance < 0:
        raise ValueError(f"lr_tolerance: expected an integer >= 0, got {lr_tolerance}")
    lr_tolerance = int(lr_tolerance)
    if aggregate is not None:
        if method in ("bm", "sgbm"):
            raise ValueError(
                f"aggregate: only the census methods aggregate, got aggregate={aggregate!r} with "
                f"method={method!r}; use aggregate=None"
            )
        aggregate = check_window(aggregate, "aggregate", image_shape=grey_l.shape)
    params: dict[str, object] = {
        "lr_check": lr_check,
        "lr_tolerance": lr_tolerance,
        "subpixel": subpixel,
        "aggregate": aggregate,
    }

    if method in _PAPER_METHODS:
        if lr_check or subpixel or aggregate is not None:
            raise ValueError(
                f"lr_check, subpixel and aggregate are not defined for method={method!r} (the "
                "paper's methods are per-pixel Hamming + winner-takes-all); leave them unset"
            )
        if method == "cthw":
            return match_cthw(left, right, window=window, max_disparity=max_disparity)
        paper_match = match_awct if method == "awct" else match_awsct
        return paper_match(left, right, max_window=window, max_disparity=max_disparity)

    if method in ("bm", "sgbm"):
        disp, cv_params = _match_opencv(
            grey_l, grey_r, method=method, window=window, max_disparity=max_disparity,
            lr_tolerance=lr_tolerance if lr_check else None, subpixel=subpixel,
        )
        params.update(cv_params)
        return MatchResult(disp, None, method, window, max_disparity,
                           types.MappingProxyType(params))

    offsets = resolve_offsets(window, "dense" if method == "ct" else "sparse")
    bits = int(offsets.shape[0])
    if aggregate is not None and aggregate * aggregate * bits >= 2**32 - 1:
        raise ValueError(
            f"aggregate: {aggregate}x{aggregate} boxes of {bits}-bit costs overflow uint32; "
            "use a smaller aggregate or window"
        )
    disp = census_disparity(
        grey_l, grey_r, offsets, window=window, max_disparity=max_disparity, aggregate=aggregate,
        lr_tolerance=lr_tolerance if lr_check else None, subpixel=subpixel,
    )
    params["n_bits"] = bits
    return MatchResult(
        disp, census_ops(grey_l.shape, bits, max_disparity), method, window, max_disparity,
        types.MappingProxyType(params),
    )
