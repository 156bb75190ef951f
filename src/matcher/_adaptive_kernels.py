"""Numba kernels of CTHW and AWCT/AWSCT. They trust their input: validate at the public boundary.

Census codes use the word-planar layout ``(H, n_words, W)`` uint64 of :mod:`matcher._kernels`
(contiguous inner loops over ``x``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels import _census_row, fetch_add, popcount64

__all__ = [
    "adaptive_wta_kernel",
    "disparity_to_int",
    "right_window_map",
    "path_mode_kernel",
    "select_windows_kernel",
]

_BIG = np.uint32(0xFFFFFFFF)


@njit(cache=True)
def _integral(edges, integral):  # pragma: no cover - compiled
    """``integral[i, j]`` = edge pixels in ``[0, i) x [0, j)``; (H + 1, W + 1) int64."""
    H, W = edges.shape
    for j in range(W + 1):
        integral[0, j] = 0
    for i in range(H):
        s = np.int64(0)
        integral[i + 1, 0] = 0
        prev = integral[i]
        cur = integral[i + 1]
        row = edges[i]
        for j in range(W):
            s += np.int64(row[j])
            cur[j + 1] = prev[j + 1] + s


@njit(parallel=True, cache=True)
def select_windows_kernel(edges, sizes, n_decreases, n_threads, counter, out):  # pragma: no cover
    """Per-pixel window choice from edge counts (see :func:`matcher.adaptive.select_windows`).

    edges : (H, W) bool. sizes : (K,) int64 odd window sides, increasing. n_decreases : N >= 1.
    n_threads : workers; counter : (1,) int64 zeros (next row).
    out : (H, W) uint8, overwritten with the chosen side.

    The proportion of window ``k`` is ``count_k / s_k**2`` (pixels outside the image count as
    non-edge). A decrease is ``count_k / s_k**2 < count_{k-1} / s_{k-1}**2``, compared exactly as
    ``count_k * s_{k-1}**2 < count_{k-1} * s_k**2``. The side chosen is the first at which N
    decreases in a row have occurred; if none, the largest. Counts come from a summed-area
    table (4 lookups per window); each row is processed window by window across ``x`` so that
    the loops vectorise.
    """
    H, W = edges.shape
    K = sizes.shape[0]
    largest = sizes[K - 1]
    integral = np.empty((H + 1, W + 1), np.int64)
    _integral(edges, integral)
    for _t in prange(n_threads):
        count = np.empty(W, np.int64)
        prev = np.empty(W, np.int64)
        run = np.empty(W, np.int64)
        chosen = np.empty(W, np.int64)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            for x in range(W):
                run[x] = 0
                chosen[x] = 0
            prev_area = np.int64(1)
            for k in range(K):
                s = sizes[k]
                r = s // 2
                y0 = max(y - r, 0)
                y1 = min(y + r + 1, H)
                top = integral[y0]
                bot = integral[y1]
                for x in range(W):
                    x0 = max(x - r, 0)
                    x1 = min(x + r + 1, W)
                    count[x] = bot[x1] - top[x1] - bot[x0] + top[x0]
                area = np.int64(s) * np.int64(s)
                if k > 0:
                    for x in range(W):
                        dec = count[x] * prev_area < prev[x] * area
                        rn = run[x] + 1 if dec else np.int64(0)
                        run[x] = rn
                        if chosen[x] == 0 and rn >= n_decreases:
                            chosen[x] = s
                for x in range(W):
                    prev[x] = count[x]
                prev_area = area
            o = out[y]
            for x in range(W):
                c = chosen[x]
                o[x] = np.uint8(c if c != 0 else largest)


@njit(cache=True)
def right_window_map(wmap, n_disp, out):  # pragma: no cover - compiled
    """``out[y, q] = max(wmap[y, q : q + n_disp])`` (the window ``"left_pixel"`` needs at ``q``).

    wmap, out : (H, W) uint8. A sliding maximum with a monotone deque, ``O(H W)``.
    """
    H, W = wmap.shape
    dq = np.empty(W, np.int64)
    for y in range(H):
        row = wmap[y]
        o = out[y]
        head = 0
        tail = 0
        # windows [q, q + n_disp) for q = W - 1 down to 0: push q, drop indices >= q + n_disp
        for q in range(W - 1, -1, -1):
            v = row[q]
            while tail > head and row[dq[tail - 1]] <= v:
                tail -= 1
            dq[tail] = q
            tail += 1
            while dq[head] >= q + n_disp:
                head += 1
            o[q] = row[dq[head]]


@njit(cache=True)
def _adaptive_row(cl, cr, bits_l, bits_r, n_disp, bufs, out, totals):  # pragma: no cover
    """Masked Hamming + WTA of one row (codes ``cl``, ``cr`` : (n_words, W) of that row)."""
    cost, bmin, bestc, bestd = bufs
    nw, W = cl.shape
    ones = np.uint64(0xFFFFFFFFFFFFFFFF)
    one = np.uint64(1)
    tb = np.int64(0)
    tw = np.int64(0)
    for x in range(W):
        bestc[x] = _BIG
        bestd[x] = 0
    for d in range(min(n_disp, W)):
        n = W - d
        c = cost[:n]
        bm = bmin[:n]
        bll = bits_l[d:]
        brr = bits_r[:n]
        for i in range(n):
            b = min(bll[i], brr[i])
            bm[i] = b
            tb += b
            c[i] = 0
        for wi in range(nw):
            left = cl[wi, d:]
            right = cr[wi, :n]
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
    for x in range(W):
        out[x] = np.float32(bestd[x])
    totals[0] = tb
    totals[1] = tw


@njit(parallel=True, cache=True)
def adaptive_wta_kernel(
    pl, pr, offsets, r, bits_l, bits_r, n_disp, n_threads, counter, out, totals
):  # pragma: no cover - compiled
    """Census codes + Hamming cost over the smaller window's prefix + winner-takes-all, fused.

    pl, pr : (H + 2r, W + 2r) edge-padded images; offsets : (n, 2) int64 census offsets of the
    largest window (each row's codes are computed here, as :func:`matcher._kernels._census_row`).
    bits_l, bits_r : (H, W) int64, the code length (a prefix) each pixel's window uses. The cost
    of ``(y, x, d)`` is the number of differing bits among the first
    ``min(bits_l[y, x], bits_r[y, x - d])`` bits. Candidates: ``0 <= d < n_disp`` with
    ``x - d >= 0``; ties go to the smallest ``d``.
    n_threads : workers; counter : (1,) int64 zeros (next row).
    out : (H, W) float32, overwritten with the integer disparity.
    totals : (H, 2) int64, overwritten: per row, the bits compared and the 64-bit words touched
    (``ceil(bits / 64)`` per pixel and candidate).
    """
    H, W = out.shape
    nw = (offsets.shape[0] + 63) // 64
    for _t in prange(n_threads):
        tmp = np.empty((8, W), np.uint8)
        cl = np.empty((nw, W), np.uint64)
        cr = np.empty((nw, W), np.uint64)
        bufs = (np.empty(W, np.uint32), np.empty(W, np.int64), np.empty(W, np.uint32),
                np.empty(W, np.int64))
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            _census_row(pl, offsets, r, y, tmp, cl)
            _census_row(pr, offsets, r, y, tmp, cr)
            _adaptive_row(cl, cr, bits_l[y], bits_r[y], n_disp, bufs, out[y], totals[y])


@njit(cache=True)
def disparity_to_int(disp, out):  # pragma: no cover - compiled
    """Integer disparities for :func:`path_mode_kernel`: ``-1`` where ``disp`` is not finite.

    disp : (H, W) float array. out : (H, W) int64, overwritten.
    Returns ``(ok, largest)``: ``ok`` is False if a finite value is negative or not an
    integer (``out`` is then incomplete); ``largest`` is the largest valid value, ``-1`` if none.
    """
    H, W = disp.shape
    largest = np.int64(-1)
    for y in range(H):
        for x in range(W):
            v = disp[y, x]
            if np.isfinite(v):
                if v < 0 or v != np.floor(v):
                    return False, largest
                iv = np.int64(v)
                out[y, x] = iv
                largest = max(largest, iv)
            else:
                out[y, x] = -1
    return True, largest


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
def path_mode_kernel(
    disp, edges, n_disp, include_edge, include_self, max_steps, block, out
):  # pragma: no cover - compiled
    """CTHW's path search (see :func:`matcher.cthw.modify_disparity`).

    disp : (H, W) int64 disparities in ``[0, n_disp)``, ``-1`` = invalid (never counted).
    edges : (H, W) bool. max_steps : pixels per direction, ``<= H + W``.
    For each pixel, the paths run left, right, up and down from it until the first edge pixel
    (counted iff ``include_edge``), the border, or ``max_steps`` pixels; the disparities met
    are counted (plus the pixel's own if ``include_self``). ``out[y, x]`` = the most frequent
    one (ties -> the smallest), ``-1`` if none was counted.
    out : (H, W) int64, overwritten.

    The left and right paths of ``(y, x)`` cover ``[lo, hi)`` of row ``y`` except ``x`` itself
    (likewise up and down in column ``x``), and ``lo``, ``hi`` never decrease along a line.
    So one histogram per row slides along ``x`` and one per column slides along ``y``, each
    in ``O(line length)`` in total; a pixel's counts are the row's plus the column's, minus its
    own disparity twice (plus once if ``include_self``): ``O(H W n_disp)`` for the vote only.
    block : columns per work item (each block sweeps all rows; its row histograms restart at
    the block's first column).
    """
    H, W = disp.shape
    n_blocks = (W + block - 1) // block
    for b in prange(n_blocks):
        x0 = b * block
        x1 = min(W, x0 + block)
        bw = x1 - x0
        lo_y = np.empty((bw, H), np.int64)
        hi_y = np.empty((bw, H), np.int64)
        col_disp = np.empty((bw, H), np.int64)
        column = np.empty(H, np.bool_)
        for j in range(bw):
            for y in range(H):
                column[y] = edges[y, x0 + j]
                col_disp[j, y] = disp[y, x0 + j]
            _path_bounds(column, include_edge, max_steps, lo_y[j], hi_y[j])
        # Histograms of the current intervals [ca, cb) (per column) and [ra, rb) (row y).
        # No array views in the pixel loop: creating one costs reference counting.
        col_hist = np.zeros((bw, n_disp), np.int32)
        ca = np.zeros(bw, np.int64)
        cb = np.zeros(bw, np.int64)
        row_hist = np.zeros(n_disp, np.int32)
        lo_x = np.empty(W, np.int64)
        hi_x = np.empty(W, np.int64)
        own_adj = np.int32(-1 if include_self else -2)
        for y in range(H):
            _path_bounds(edges[y], include_edge, max_steps, lo_x, hi_x)
            for dd in range(n_disp):
                row_hist[dd] = 0
            ra = np.int64(0)
            rb = np.int64(0)
            for j in range(bw):
                x = x0 + j
                # slide the row interval to [lo, hi) (both ends only grow along the row)
                lo = lo_x[x]
                hi = hi_x[x]
                if lo >= rb:
                    for i in range(ra, rb):
                        v = disp[y, i]
                        if v >= 0:
                            row_hist[v] -= 1
                    ra = lo
                    rb = lo
                while rb < hi:
                    v = disp[y, rb]
                    if v >= 0:
                        row_hist[v] += 1
                    rb += 1
                while ra < lo:
                    v = disp[y, ra]
                    if v >= 0:
                        row_hist[v] -= 1
                    ra += 1
                # slide column x's interval likewise along y
                lo = lo_y[j, y]
                hi = hi_y[j, y]
                a = ca[j]
                c = cb[j]
                if lo >= c:
                    for i in range(a, c):
                        v = col_disp[j, i]
                        if v >= 0:
                            col_hist[j, v] -= 1
                    a = lo
                    c = lo
                while c < hi:
                    v = col_disp[j, c]
                    if v >= 0:
                        col_hist[j, v] += 1
                    c += 1
                while a < lo:
                    v = col_disp[j, a]
                    if v >= 0:
                        col_hist[j, v] -= 1
                    a += 1
                ca[j] = a
                cb[j] = c
                # vote: row + column counts, the own disparity counted once or not at all
                own = disp[y, x]
                if own >= 0:
                    row_hist[own] += own_adj
                best = np.int64(-1)
                best_count = np.int32(0)
                for dd in range(n_disp):
                    cnt = row_hist[dd] + col_hist[j, dd]
                    if cnt > best_count:
                        best = dd
                        best_count = cnt
                if own >= 0:
                    row_hist[own] -= own_adj
                out[y, x] = best
