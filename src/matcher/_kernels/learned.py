"""Numba kernel of the learned matcher's cost: cosine similarity of feature vectors, quantised.

Features arrive L2-normalised in the layout ``(H, C, W)`` ("channel-planar", like the census
codes' ``(H, n_words, W)``), so the inner loop runs over ``x`` on contiguous rows. Rows are taken
from a shared atomic counter (:func:`matcher._kernels.intrinsics.fetch_add`), as in
:mod:`matcher._kernels.census`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels.census import COST_SENTINEL
from matcher._kernels.intrinsics import fetch_add

__all__ = ["similarity_cost_kernel"]


@njit(parallel=True, cache=True)
def similarity_cost_kernel(fl, fr, scale, n_threads, counter, out):  # pragma: no cover
    """``out[y, d, x] = round((1 - <fl[y, :, x], fr[y, :, x - d]>) * scale)``, clipped to
    ``0 .. 65534``; ``COST_SENTINEL`` where ``x - d < 0``.

    fl, fr : (H, C, W) float32, unit vectors along C. scale : float32 (> 0).
    n_threads : workers (``numba.get_num_threads()``). counter : (1,) int64 zeros (the next row).
    out : (H, D, W) uint16, overwritten.
    """
    H, D, W = out.shape
    C = fl.shape[1]
    one = np.float32(1.0)
    half = np.float32(0.5)
    top = np.float32(65534.0)
    for _t in prange(n_threads):
        acc = np.empty(W, np.float32)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            for d in range(D):
                o = out[y, d]
                for x in range(min(d, W)):
                    o[x] = COST_SENTINEL
                n = W - d
                if n <= 0:
                    continue
                a = acc[:n]
                for i in range(n):
                    a[i] = np.float32(0.0)
                for c in range(C):
                    lrow = fl[y, c, d:]
                    rrow = fr[y, c, :n]
                    for i in range(n):
                        a[i] += lrow[i] * rrow[i]
                od = o[d:]
                for i in range(n):
                    v = (one - a[i]) * scale + half
                    if v < 0:
                        v = np.float32(0.0)
                    elif v > top:
                        v = top
                    od[i] = np.uint16(v)
