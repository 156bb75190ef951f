"""Numba kernel of the box aggregation of full ``(H, D, W)`` cost volumes
(:func:`matcher.cost.aggregate_cost`). It trusts its input: validate at the public boundary.

For each disparity ``d`` the box runs over the valid columns ``[d, W)`` with the edge
replicated (columns ``< d`` read column ``d``, columns past ``W - 1`` read ``W - 1``, rows
outside read the nearest row). A worker takes a strip of rows from the shared counter
(:func:`matcher._kernels.intrinsics.fetch_add`) and, per disparity, slides a vertical column
sum down the strip (one row added, one removed: two operations per element whatever the box
size), then a horizontal running sum along the column sums, edge-padded in place. All of it is
integer arithmetic modulo ``2**32`` (the differences of running sums wrap and cancel), so a box
sum that fits uint32, as every box of side <= 255 of uint16 costs does (31 x 31 boxes of 65535
are 62 979 135), is exact, and a larger one wraps as an int64 sum cast to uint32 does.

The fused census matcher (:mod:`matcher._kernels.census`) aggregates its own strips
(``_hbox``) and does not call this kernel.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels.intrinsics import fetch_add

__all__ = ["AGG_SENTINEL", "aggregate_kernel"]

#: Aggregated cost stored where ``x - d < 0`` (not a candidate).
AGG_SENTINEL = np.uint32(0xFFFFFFFF)


@njit(cache=True)
def _strip_disparity(cost, d, h, y0, y1, col, out):  # pragma: no cover - compiled
    """Rows ``[y0, y1)`` of ``out[:, d]`` for one valid disparity ``d < W``.

    col : (W + 2h,) uint32 scratch; ``col[h : h + n]`` holds the vertical sums of the ``n = W - d``
    valid columns, ``col[:h]`` and ``col[h + n : 2h + n]`` their replicated edges.
    """
    H, _, W = cost.shape
    n = W - d
    mid = col[h : h + n]
    src = cost[min(max(y0 - h, 0), H - 1), d, d:]
    for i in range(n):
        mid[i] = np.uint32(src[i])
    for yy in range(y0 - h + 1, y0 + h + 1):
        src = cost[min(max(yy, 0), H - 1), d, d:]
        for i in range(n):
            mid[i] += np.uint32(src[i])
    left = col[:h]
    right = col[h + n : 2 * h + n]
    lo = col[: n - 1]
    hi = col[2 * h + 1 : 2 * h + n]
    for y in range(y0, y1):
        if y > y0:
            old = cost[max(y - h - 1, 0), d, d:]
            new = cost[min(y + h, H - 1), d, d:]
            for i in range(n):
                mid[i] += np.uint32(new[i]) - np.uint32(old[i])
        first = mid[0]
        last = mid[n - 1]
        for k in range(h):
            left[k] = first
            right[k] = last
        s = np.uint32(0)
        for k in range(2 * h + 1):
            s += col[k]
        o = out[y, d]
        for x in range(d):
            o[x] = AGG_SENTINEL
        od = o[d:]
        for i in range(n - 1):
            od[i] = s
            s += hi[i] - lo[i]
        od[n - 1] = s


@njit(parallel=True, cache=True)
def aggregate_kernel(cost, h, strip, n_threads, counter, out):  # pragma: no cover - compiled
    """Box sums of side ``2h + 1`` of every ``cost[:, d]`` over its valid columns ``x >= d``.

    cost : (H, D, W) uint16, C-contiguous, ``H, D, W >= 1``. h : half side, >= 1.
    strip : rows per work item. n_threads : ``numba.get_num_threads()`` (read by the caller: calling
    it here would stop numba from caching the kernel). counter : (1,) int64 zeros, the shared strip
    counter. out : (H, D, W) uint32, overwritten everywhere (:data:`AGG_SENTINEL` where
    ``x - d < 0``, all of ``out[:, d]`` for ``d >= W``).
    """
    H, D, W = cost.shape
    n_valid = min(D, W)
    n_items = (H + strip - 1) // strip
    for _t in prange(n_threads):
        col = np.empty(W + 2 * h, np.uint32)
        while True:
            s = fetch_add(counter, 1)
            if s >= n_items:
                break
            y0 = s * strip
            y1 = min(H, y0 + strip)
            for d in range(n_valid):
                _strip_disparity(cost, d, h, y0, y1, col, out)
            for d in range(n_valid, D):
                for y in range(y0, y1):
                    o = out[y, d]
                    for x in range(W):
                        o[x] = AGG_SENTINEL
