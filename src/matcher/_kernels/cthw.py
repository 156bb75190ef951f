"""Numba kernels of CTHW (:mod:`matcher.cthw`): Haar bands straight into padded census input,
and the path search with the upsampling to full resolution fused.

They trust their input: validate at the public boundary.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["disparity_range", "haar_padded_kernel", "key_shift", "path_mode_up_kernel"]


def key_shift(n_disp: int) -> int:
    """Bits that hold the disparity in a vote key: the least ``sh`` with ``2**sh >= n_disp``.

    Examples
    --------
    >>> key_shift(1), key_shift(32), key_shift(33)
    (0, 5, 6)
    """
    return max(0, (int(n_disp) - 1).bit_length())


@njit(cache=True)
def disparity_range(disp):  # pragma: no cover - compiled
    """Check integer disparities for the path search: ``(ok, largest)``.

    disp : (H, W) float array; non-finite values are invalid (never counted). ``ok`` is False
    if a finite value is negative or not an integer; ``largest`` is the largest finite value
    (``-1`` if none, or where ``ok`` turned False).
    """
    H, W = disp.shape
    largest = np.int64(-1)
    for y in range(H):
        for x in range(W):
            v = disp[y, x]
            if np.isfinite(v):
                if v < 0 or v != np.floor(v):
                    return False, largest
                largest = max(largest, np.int64(v))
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


@njit(cache=True)
def _haar_row(grey, i, r, ll, hh):  # pragma: no cover - compiled
    """Row ``i`` of the 2 x 2 sums: ``ll[r : r + w2]`` (uint16), ``hh`` (w2,) int16, and the
    ``r`` replicated pixels on each side of ``ll``."""
    H, W = grey.shape
    w2 = hh.shape[0]
    r0 = grey[2 * i]
    r1 = grey[min(2 * i + 1, H - 1)]
    o = ll[r : r + w2]
    for j in range(w2):
        j1 = min(2 * j + 1, W - 1)
        a = np.int32(r0[2 * j])
        b = np.int32(r0[j1])
        c = np.int32(r1[2 * j])
        d = np.int32(r1[j1])
        o[j] = np.uint16(a + b + c + d)
        hh[j] = np.int16(a - b - c + d)
    first = o[0]
    last = o[w2 - 1]
    for j in range(r):
        ll[j] = first
        ll[r + w2 + j] = last


@njit(parallel=True, cache=True)
def haar_padded_kernel(grey_l, grey_r, r, thr, pl, pr, hh_l, edges):  # pragma: no cover
    """Integer Haar sums of both uint8 views, edge-padded by ``r``, and the left ``HH`` edges.

    grey_l, grey_r : (H, W) uint8. pl, pr : (ceil(H/2) + 2r, ceil(W/2) + 2r) uint16,
    overwritten with ``a + b + c + d`` of each 2 x 2 block (odd sides replicate the last
    row/column, as :func:`matcher.haar.haar2d`), padded as ``np.pad(mode="edge")``.
    hh_l : (ceil(H/2), ceil(W/2)) int16, overwritten with the left ``a - b - c + d``.
    edges : same shape, bool, overwritten with ``|hh_l * 0.25| > thr`` (float64, as
    :func:`matcher.cthw.hh_edges` on the ``"average"`` scale) unless ``thr < 0``.
    """
    h2, w2 = hh_l.shape
    rows = h2 + 2 * r  # padded rows of one view; pad rows are their edge row recomputed
    for k in prange(2 * rows):
        i = k % rows
        src = min(max(i - r, 0), h2 - 1)
        if k < rows:
            if i == r + src:  # an image row: its HH (and edges) too
                _haar_row(grey_l, src, r, pl[i], hh_l[src])
                if thr >= 0:
                    e = edges[src]
                    hrow = hh_l[src]
                    for j in range(w2):
                        e[j] = abs(np.float64(hrow[j]) * 0.25) > thr
            else:
                _haar_row(grey_l, src, r, pl[i], np.empty(w2, np.int16))
        else:
            _haar_row(grey_r, src, r, pr[i], np.empty(w2, np.int16))


@njit(cache=True, inline="always")
def _slide(line, hist, unit, a, c, lo, hi):  # pragma: no cover - compiled
    """Move a line histogram from the interval ``[a, c)`` to ``[lo, hi)`` (``a <= lo``,
    ``c <= hi``); ``line`` values ``< 0`` are not counted. Returns ``(lo, hi)``."""
    if lo >= c:
        for i in range(a, c):
            v = line[i]
            if v >= 0:
                hist[v] -= unit
        a = lo
        c = lo
    while c < hi:
        v = line[c]
        if v >= 0:
            hist[v] += unit
        c += 1
    while a < lo:
        v = line[a]
        if v >= 0:
            hist[v] -= unit
        a += 1
    return a, c


@njit(parallel=True, cache=True)
def path_mode_up_kernel(
    disp, edges, n_disp, sh, include_edge, include_self, max_steps, block, up, key_proto, out
):  # pragma: no cover - compiled
    """CTHW's path search (:func:`matcher.cthw.modify_disparity`), written upsampled.

    disp : (H, W) float32/float64 integer-valued disparities in ``[0, n_disp)``; non-finite
    values are invalid and never counted. edges : (H, W) bool. sh : :func:`key_shift` of
    ``n_disp``. max_steps : pixels per direction, ``<= H + W``. block : columns per work item.
    up : 1 or 2. key_proto : empty array whose dtype (int32 or int64) holds the vote keys;
    ``(H + W + 2) << sh`` must fit in it. out : (h, w) float32 with ``up * (H - 1) < h <= up *
    H`` (likewise ``w``), overwritten: the mode of coarse pixel ``(y, x)``, times ``up``, in
    every ``out[up y + i, up x + j]`` (``0 <= i, j < up``, inside ``out``), ``inf`` where
    nothing was counted.

    The left and right paths of ``(y, x)`` (:func:`_path_bounds`) cover ``[lo, hi)`` of row
    ``y`` minus ``x`` (likewise up and down in column ``x``), and both ends never decrease
    along a line, so one histogram per row and one per column slide (:func:`_slide`); a
    pixel's counts are the row's plus the column's, its own disparity corrected (counted
    once, or not at all). Blocks of columns run in parallel; each starts its row histograms
    from the state at its first column, computed once per row beforehand. The histograms
    hold *keys*: a count ``c`` of disparity ``d`` is ``c << sh``, and each column histogram
    starts at ``2**sh - 1 - d``; the vote's maximum key then holds
    the largest count in its high bits and, among the disparities with that count, the
    smallest ``d`` in its low bits (one vectorised maximum, no second search).
    """
    H, W = disp.shape
    unit = key_proto.dtype.type(1) << key_proto.dtype.type(sh)
    n_blocks = (W + block - 1) // block
    di = np.empty((H, W), np.int32)
    lo_xs = np.empty((H, W), np.int32)
    hi_xs = np.empty((H, W), np.int32)
    # per row, the row histogram at each block's first column, so that no block has to
    # fill it again from its row's start (one pass per row in all)
    starts = np.empty((H, n_blocks, n_disp), key_proto.dtype)
    for y in prange(H):
        src = disp[y]
        dst = di[y]
        for x in range(W):
            v = src[x]
            dst[x] = np.int32(v) if np.isfinite(v) else np.int32(-1)
        _path_bounds(edges[y], include_edge, max_steps, lo_xs[y], hi_xs[y])
        hist = starts[y, 0]
        for dd in range(n_disp):
            hist[dd] = 0
        ra, rb = _slide(dst, hist, unit, 0, 0, lo_xs[y, 0], hi_xs[y, 0])
        for b in range(1, n_blocks):
            nxt = starts[y, b]
            for dd in range(n_disp):
                nxt[dd] = hist[dd]
            hist = nxt
            ra, rb = _slide(dst, hist, unit, ra, rb, lo_xs[y, b * block], hi_xs[y, b * block])
    low_mask = unit - key_proto.dtype.type(1)
    own_adj = unit * key_proto.dtype.type(-1 if include_self else -2)
    zero = key_proto.dtype.type(0)
    oh, ow = out.shape
    ush = 1 if up == 2 else 0  # up is 1 or 2
    inf = np.float32(np.inf)
    for b in prange(n_blocks):
        x0 = b * block
        x1 = min(W, x0 + block)
        bw = x1 - x0
        # (H, bw): the pixel loop reads a row of them at a time
        lo_y = np.empty((H, bw), np.int32)
        hi_y = np.empty((H, bw), np.int32)
        for j in range(bw):
            _path_bounds(edges[:, x0 + j], include_edge, max_steps, lo_y[:, j], hi_y[:, j])
        col_hist = np.empty((bw, n_disp), key_proto.dtype)
        for j in range(bw):
            for dd in range(n_disp):
                col_hist[j, dd] = low_mask - key_proto.dtype.type(dd)
            # the own-disparity correction of row 0 (see the vote below)
            own = di[0, x0 + j]
            if own >= 0:
                col_hist[j, own] += own_adj
        ca = np.zeros(bw, np.int64)
        cb = np.zeros(bw, np.int64)
        row_hist = np.empty(n_disp, key_proto.dtype)
        res = np.empty(bw, np.float32)
        for y in range(H):
            lo_x = lo_xs[y]
            hi_x = hi_xs[y]
            drow = di[y]
            first = starts[y, b]
            for dd in range(n_disp):
                row_hist[dd] = first[dd]
            ra = lo_x[x0]
            rb = hi_x[x0]
            # no array views inside this loop: creating one costs reference counting
            for j in range(bw):
                x = x0 + j
                ra, rb = _slide(drow, row_hist, unit, ra, rb, lo_x[x], hi_x[x])
                # the column's slide, written out: col_hist[j] as a view costs a reference
                lo = lo_y[y, j]
                hi = hi_y[y, j]
                a = ca[j]
                c = cb[j]
                if lo >= c:
                    for i in range(a, c):
                        v = di[i, x]
                        if v >= 0:
                            col_hist[j, v] -= unit
                    a = lo
                    c = lo
                while c < hi:
                    v = di[c, x]
                    if v >= 0:
                        col_hist[j, v] += unit
                    c += 1
                while a < lo:
                    v = di[a, x]
                    if v >= 0:
                        col_hist[j, v] -= unit
                    a += 1
                ca[j] = a
                cb[j] = c
                # vote: the pixel's own disparity is in both intervals; its correction
                # (counted once, or not at all) already sits in the column histogram, put
                # there one row ahead so that the vector loads here never wait on it
                best = zero
                for dd in range(n_disp):
                    best = max(best, row_hist[dd] + col_hist[j, dd])
                own = di[y, x]
                if own >= 0:
                    col_hist[j, own] -= own_adj
                if y + 1 < H:
                    own = di[y + 1, x]
                    if own >= 0:
                        col_hist[j, own] += own_adj
                val = inf
                if best >= unit:  # a count of at least 1
                    val = np.float32(up * (np.int64(low_mask) - np.int64(best & low_mask)))
                res[j] = val
            # the block's cells of the up rows of out: one contiguous run, then copies
            oy = up * y
            o0 = up * x0
            n = min(up * bw, ow - o0)
            orow = out[oy]
            for i in range(n):
                orow[o0 + i] = res[i >> ush]
            for iy in range(1, up):
                if oy + iy < oh:
                    nxt = out[oy + iy]
                    for i in range(n):
                        nxt[o0 + i] = orow[o0 + i]
