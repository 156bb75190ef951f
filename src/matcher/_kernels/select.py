"""Numba kernel of winner-takes-all over a full ``(H, D, W)`` cost volume
(:func:`matcher.select.winner_takes_all`). It trusts its input: validate at the public boundary.

It follows the numpy code it replaced operation for operation, not only the documented rules,
so that its output is the same for any volume, one whose entries ``x - d < 0`` do not hold the
sentinel included:

* left WTA: the first minimum over all ``D`` entries of ``cost[y, :, x]`` (``np.argmin``);
* right WTA: the first minimum of ``cost[y, d, xr + d]`` over ``d < min(D, W - xr)`` (the
  sentinel entries that the right view adds after them never win a first minimum);
* the partner of ``x`` is ``x - d_L``, wrapped once by ``W`` when negative as numpy's indexing
  wraps it (further out, the caller raises ``IndexError`` as numpy did);
* the parabola in float64 with the same operations in the same order, then float32.

The fused census matcher selects with its own ``_select_row`` (:mod:`matcher._kernels.census`),
which sees only the valid candidates; this kernel is not on its path.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels.intrinsics import fetch_add

__all__ = ["wta_kernel"]


@njit(cache=True)
def _first_min(cost, right, bestc, bestd):  # pragma: no cover - compiled
    """First minimum over ``d`` of each column of ``cost`` (D, W), seen from the left or right view.

    Left: over every ``d`` of ``cost[d, x]``. Right: of ``cost[d, xr + d]`` over
    ``d < min(D, W - xr)``. bestc : (W,) uint32, bestd : (W,) int32 (uint16 costs widened, and
    one index width, keep the compare-and-select loop vectorised).
    """
    D, W = cost.shape
    c = cost[0]
    for x in range(W):
        bestc[x] = np.uint32(c[x])
        bestd[x] = np.int32(0)
    for d in range(1, min(D, W) if right else D):
        c = cost[d, d:] if right else cost[d]
        dd = np.int32(d)
        for i in range(c.shape[0]):
            v = np.uint32(c[i])
            better = v < bestc[i]
            bestc[i] = v if better else bestc[i]
            bestd[i] = dd if better else bestd[i]


@njit(cache=True)
def _select_full_row(cost, lr_tol, subpix, bufs, out, bad):  # pragma: no cover - compiled
    """Disparities of one row: ``cost`` (D, W) -> ``out`` (W,) float32."""
    bestc, bestd, bestcr, bestdr = bufs
    D, W = cost.shape
    _first_min(cost, False, bestc, bestd)
    if lr_tol >= 0:
        _first_min(cost, True, bestcr, bestdr)
    for x in range(W):
        d = bestd[x]
        val = np.float64(d)
        if subpix and d >= 1 and d <= D - 2 and x - d - 1 >= 0:
            cm = np.float64(cost[d - 1, x])
            cp = np.float64(cost[d + 1, x])
            c0 = np.float64(bestc[x])
            den = cm - 2.0 * c0 + cp
            if den > 0.0:
                val = val + (cm - cp) / (2.0 * den)
        if lr_tol >= 0:
            xr = x - d
            if xr < 0:
                xr += W
            if xr < 0:
                bad[0] = 1
            elif abs(d - bestdr[xr]) > lr_tol:
                val = np.inf
        out[x] = np.float32(val)


@njit(parallel=True, cache=True)
def wta_kernel(cost, lr_tol, subpix, n_threads, counter, out, bad):  # pragma: no cover - compiled
    """Winner-takes-all, optional parabola subpixel and LR check, one row per work item.

    cost : (H, D, W) uint16 or uint32, C-contiguous, ``D >= 1``. lr_tol : LR tolerance (at most
    ``D``), < 0 disables. subpix : parabola refinement. n_threads : ``numba.get_num_threads()``
    (read by the caller). counter : (1,) int64 zeros, the shared row counter. out : (H, W)
    float32, overwritten (inf where the LR check fails). bad : (1,) int64 zeros, set to 1 when a
    partner column ``x - d_L`` lies below ``-W`` (only a volume whose entries ``x - d < 0`` are
    not the sentinel, with ``D > W + 1``, gets there).
    """
    H, D, W = cost.shape
    for _t in prange(n_threads):
        bestc = np.empty(W, np.uint32)
        bestd = np.empty(W, np.int32)
        bestcr = np.empty(W, np.uint32)
        bestdr = np.empty(W, np.int32)
        bufs = (bestc, bestd, bestcr, bestdr)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            _select_full_row(cost[y], lr_tol, subpix, bufs, out[y], bad)
