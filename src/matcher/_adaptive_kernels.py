"""Numba kernels of CTHW and AWCT/AWSCT. They trust their input: validate at the public boundary.

Census codes use the word-planar layout ``(H, n_words, W)`` uint64 of :mod:`matcher._kernels`
(contiguous inner loops over ``x``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels import popcount64

__all__ = [
    "adaptive_wta_kernel",
    "path_mode_kernel",
    "select_windows_kernel",
]

_BIG = np.uint32(0xFFFFFFFF)


@njit(parallel=True, cache=True)
def select_windows_kernel(integral, sizes, n_decreases, out):  # pragma: no cover - compiled
    """Per-pixel window choice from edge counts (see :func:`matcher.adaptive.select_windows`).

    integral : (H + 1, W + 1) int64, ``integral[i, j]`` = edge pixels in ``[0, i) x [0, j)``.
    sizes : (K,) int64 odd window sides, increasing. n_decreases : N >= 1.
    out : (H, W) uint8, overwritten with the chosen side.

    The proportion of window ``k`` is ``count_k / s_k**2`` (pixels outside the image count as
    non-edge). A decrease is ``count_k / s_k**2 < count_{k-1} / s_{k-1}**2``, compared exactly as
    ``count_k * s_{k-1}**2 < count_{k-1} * s_k**2``. The side chosen is the first at which N
    decreases in a row have occurred; if none, the largest.
    """
    H = integral.shape[0] - 1
    W = integral.shape[1] - 1
    K = sizes.shape[0]
    largest = sizes[K - 1]
    for y in prange(H):
        for x in range(W):
            chosen = largest
            rl = largest // 2
            ly0 = max(y - rl, 0)
            ly1 = min(y + rl + 1, H)
            lx0 = max(x - rl, 0)
            lx1 = min(x + rl + 1, W)
            if integral[ly1, lx1] - integral[ly0, lx1] - integral[ly1, lx0] + integral[ly0, lx0] == 0:
                out[y, x] = np.uint8(largest)  # no edge anywhere: never a decrease
                continue
            run = 0
            prev_count = np.int64(0)
            prev_area = np.int64(1)
            for k in range(K):
                r = sizes[k] // 2
                y0 = max(y - r, 0)
                y1 = min(y + r + 1, H)
                x0 = max(x - r, 0)
                x1 = min(x + r + 1, W)
                count = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
                area = np.int64(sizes[k]) * np.int64(sizes[k])
                if k > 0:
                    if count * prev_area < prev_count * area:
                        run += 1
                    else:
                        run = 0
                    if run >= n_decreases:
                        chosen = sizes[k]
                        break
                prev_count = count
                prev_area = area
            out[y, x] = np.uint8(chosen)


@njit(parallel=True, cache=True)
def adaptive_wta_kernel(cl, cr, bits_l, bits_r, n_disp, out, totals):  # pragma: no cover
    """Census Hamming cost over the smaller window's prefix + winner-takes-all, fused.

    cl, cr : (H, n_words, W) uint64 codes at the largest window. bits_l, bits_r : (H, W) int64,
    the code length (a prefix) each pixel's window uses. The cost of ``(y, x, d)`` is the number
    of differing bits among the first ``min(bits_l[y, x], bits_r[y, x - d])`` bits. Candidates:
    ``0 <= d < n_disp`` with ``x - d >= 0``; ties go to the smallest ``d``.
    out : (H, W) float32, overwritten with the integer disparity.
    totals : (H, 2) int64, overwritten: per row, the bits compared and the 64-bit words touched
    (``ceil(bits / 64)`` per pixel and candidate).
    """
    H = cl.shape[0]
    nw = cl.shape[1]
    W = cl.shape[2]
    ones = np.uint64(0xFFFFFFFFFFFFFFFF)
    one = np.uint64(1)
    for y in prange(H):
        cost = np.empty(W, np.uint32)
        bmin = np.empty(W, np.int64)
        bestc = np.empty(W, np.uint32)
        bestd = np.empty(W, np.int64)
        tb = np.int64(0)
        tw = np.int64(0)
        for x in range(W):
            bestc[x] = _BIG
            bestd[x] = 0
        for d in range(min(n_disp, W)):
            n = W - d
            c = cost[:n]
            bm = bmin[:n]
            bll = bits_l[y, d:]
            brr = bits_r[y, :n]
            for i in range(n):
                b = min(bll[i], brr[i])
                bm[i] = b
                tb += b
                c[i] = 0
            for wi in range(nw):
                left = cl[y, wi, d:]
                right = cr[y, wi, :n]
                base = 64 * wi
                for i in range(n):
                    rem = bm[i] - base
                    if rem >= 64:
                        m = ones
                    elif rem > 0:
                        m = (one << np.uint64(rem)) - one
                    else:
                        m = np.uint64(0)
                    tw += 1 if rem > 0 else 0
                    c[i] += np.uint32(popcount64((left[i] ^ right[i]) & m))
            bc = bestc[d:]
            bd = bestd[d:]
            for i in range(n):
                if c[i] < bc[i]:
                    bc[i] = c[i]
                    bd[i] = d
        o = out[y]
        for x in range(W):
            o[x] = np.float32(bestd[x])
        totals[y, 0] = tb
        totals[y, 1] = tw


@njit(cache=True)
def _path_bounds(edges_line, include_edge, max_steps, lo, hi):  # pragma: no cover - compiled
    """Path intervals along one line: ``[lo[i], i)`` backwards and ``(i, hi[i])`` forwards.

    A path walks away from ``i`` until the first edge pixel (included iff ``include_edge``),
    the end of the line, or ``max_steps`` pixels.
    """
    n = edges_line.shape[0]
    last = -1
    for i in range(n):
        start = 0
        if last >= 0:
            start = last if include_edge else last + 1
        lo[i] = max(start, i - max_steps)
        if edges_line[i]:
            last = i
    nxt = n
    for i in range(n - 1, -1, -1):
        end = n
        if nxt < n:
            end = nxt + 1 if include_edge else nxt
        hi[i] = min(end, i + 1 + max_steps)
        if edges_line[i]:
            nxt = i


@njit(parallel=True, cache=True)
def path_mode_kernel(disp, edges, n_disp, include_edge, include_self, max_steps, out):  # pragma: no cover
    """CTHW's path search (see :func:`matcher.cthw.modify_disparity`).

    disp : (H, W) int64 disparities in ``[0, n_disp)``, ``-1`` = invalid (never counted).
    edges : (H, W) bool. max_steps : pixels per direction, ``<= H + W``.
    For each pixel, the paths run left, right, up and down from it until the first edge pixel
    (counted iff ``include_edge``), the border, or ``max_steps`` pixels; the disparities met
    are counted (plus the pixel's own if ``include_self``). ``out[y, x]`` = the most frequent
    one (ties -> the smallest), ``-1`` if none was counted.
    Per-line prefix histograms make each pixel ``O(n_disp)`` whatever its path lengths.
    out : (H, W) int64, overwritten.
    """
    H, W = disp.shape
    prow = np.zeros((H, W + 1, n_disp), np.int32)
    pcol = np.zeros((W, H + 1, n_disp), np.int32)
    lo_x = np.empty((H, W), np.int64)
    hi_x = np.empty((H, W), np.int64)
    lo_y = np.empty((W, H), np.int64)
    hi_y = np.empty((W, H), np.int64)
    for y in prange(H):
        for x in range(W):
            prow[y, x + 1, :] = prow[y, x, :]
            d = disp[y, x]
            if d >= 0:
                prow[y, x + 1, d] += 1
        _path_bounds(edges[y, :], include_edge, max_steps, lo_x[y], hi_x[y])
    for x in prange(W):
        column = np.empty(H, np.bool_)
        for y in range(H):
            pcol[x, y + 1, :] = pcol[x, y, :]
            d = disp[y, x]
            if d >= 0:
                pcol[x, y + 1, d] += 1
            column[y] = edges[y, x]
        _path_bounds(column, include_edge, max_steps, lo_y[x], hi_y[x])
    for y in prange(H):
        for x in range(W):
            a = prow[y, lo_x[y, x]]
            b = prow[y, x]
            c = prow[y, x + 1]
            e = prow[y, hi_x[y, x]]
            f = pcol[x, lo_y[x, y]]
            g = pcol[x, y]
            h = pcol[x, y + 1]
            k = pcol[x, hi_y[x, y]]
            own = disp[y, x] if include_self else -1
            best = np.int64(-1)
            best_count = 0
            for dd in range(n_disp):
                cnt = (b[dd] - a[dd]) + (e[dd] - c[dd]) + (g[dd] - f[dd]) + (k[dd] - h[dd])
                if dd == own:
                    cnt += 1
                if cnt > best_count:
                    best = dd
                    best_count = cnt
            out[y, x] = best
