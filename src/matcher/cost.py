"""Hamming cost volumes of census codes, and their optional box aggregation.

Layout ``(H, D, W)``: one ``(D, W)`` slab per image row, so that winner-takes-all over ``d`` runs
over contiguous rows of ``W`` costs. A left pixel ``(y, x)`` has candidates ``d = 0 .. D - 1``
with ``x - d >= 0`` (conventions: it matches the right pixel ``x - d``); entries with
``x - d < 0`` hold :data:`COST_SENTINEL` and are never chosen.

These full volumes are the transparent reference path; :func:`matcher.match` uses a fused kernel
that never builds them and gives bit-identical disparities.
"""

from __future__ import annotations

import numba
import numpy as np

from matcher._kernels import AGG_SENTINEL, COST_SENTINEL, aggregate_kernel, cost_volume_kernel
from matcher._validation import check_max_disparity

__all__ = ["AGG_SENTINEL", "COST_SENTINEL", "aggregate_cost", "cost_volume"]


def _check_codes(codes: object, name: str) -> np.ndarray:
    if not isinstance(codes, np.ndarray) or codes.dtype != np.uint64 or codes.ndim != 3:
        got = (
            f"array of shape {codes.shape} and dtype {codes.dtype}"
            if isinstance(codes, np.ndarray)
            else type(codes).__name__
        )
        raise TypeError(
            f"{name}: expected (H, W, n_words) uint64 census codes, got {got}; "
            "use matcher.census_transform"
        )
    return codes


def cost_volume(codes_left: np.ndarray, codes_right: np.ndarray, *, max_disparity: int) -> np.ndarray:
    """Per-pixel Hamming costs between left and right census codes.

    Parameters
    ----------
    codes_left, codes_right : (H, W, n_words) uint64 arrays
        Codes of the left and right views (same window and pattern).
    max_disparity : int
        Number of candidates ``D`` (disparities ``0 .. D - 1``), ``1 <= D < W``.

    Returns
    -------
    (H, D, W) uint16 array
        ``cost[y, d, x] = hamming(left[y, x], right[y, x - d])``; :data:`COST_SENTINEL` (65535)
        where ``x - d < 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from matcher.census import census_transform
    >>> img = np.random.default_rng(0).integers(0, 255, (8, 12), dtype=np.uint8)
    >>> c = census_transform(img, window=3)
    >>> cv = cost_volume(c, c, max_disparity=4)
    >>> cv.shape, int(cv[:, 0].max()), int(cv[0, 3, 2])
    ((8, 4, 12), 0, 65535)
    """
    cl = _check_codes(codes_left, "codes_left")
    cr = _check_codes(codes_right, "codes_right")
    if cl.shape != cr.shape:
        raise ValueError(
            f"codes_left and codes_right: expected the same shape, got {cl.shape} and {cr.shape}; "
            "transform both views with the same window and pattern"
        )
    h, w, _ = cl.shape
    d = check_max_disparity(max_disparity, w)
    out = np.empty((h, d, w), dtype=np.uint16)
    cost_volume_kernel(_planar(cl), _planar(cr), out)
    return out


def _planar(codes: np.ndarray) -> np.ndarray:
    """(H, W, n_words) -> the kernels' contiguous (H, n_words, W)."""
    return np.ascontiguousarray(codes.transpose(0, 2, 1))


def aggregate_cost(cost: np.ndarray, *, size: int) -> np.ndarray:
    """Box-sum a cost volume over ``size x size`` pixels, per disparity.

    For disparity ``d`` the valid columns are ``x >= d``; the box is summed over that valid region
    with its edge replicated (columns ``< d`` read column ``d``; rows outside the image read the
    nearest row), so no sentinel enters a sum.

    Parameters
    ----------
    cost : (H, D, W) uint16 array
        From :func:`cost_volume`.
    size : int
        Odd box side >= 3.

    Returns
    -------
    (H, D, W) uint32 array
        Aggregated costs; :data:`AGG_SENTINEL` where ``x - d < 0``.

    Examples
    --------
    >>> import numpy as np
    >>> agg = aggregate_cost(np.ones((4, 2, 6), np.uint16), size=3)
    >>> int(agg[2, 1, 3]), int(agg[0, 1, 0])
    (9, 4294967295)
    """
    if not isinstance(cost, np.ndarray) or cost.ndim != 3 or cost.dtype != np.uint16:
        raise TypeError("cost: expected an (H, D, W) uint16 volume; use cost_volume")
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 3 or size % 2 == 0:
        raise ValueError(f"size: expected an odd integer >= 3, got {size!r}")
    out = np.empty(cost.shape, dtype=np.uint32)
    if cost.size:
        n_threads = numba.get_num_threads()
        # at least one box of rows per strip (its first row costs 2h + 1 row additions, the others
        # 2), and about four strips per worker
        strip = max(size, -(-cost.shape[0] // (4 * n_threads)))
        aggregate_kernel(
            np.ascontiguousarray(cost), size // 2, strip, n_threads, np.zeros(1, np.int64), out
        )
    return out
