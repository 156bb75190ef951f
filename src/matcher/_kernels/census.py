"""Numba kernels of the census matcher (CT/SCT and cost volumes). They trust their input:
validate at the public boundary.

Layouts used here (chosen for contiguous, vectorisable inner loops over ``x``):

* census codes: ``(H, n_words, W)`` uint64 ("word-planar"); the public API exposes
  ``(H, W, n_words)``;
* cost rows and volumes: ``(D, W)`` per row, ``(H, D, W)`` per image.

Inner loops index from 0 on sliced views, so every index is provably non-negative and numba's
negative-index wraparound check does not block vectorisation.

Scheduling: the parallel kernels that do most of the work run ``prange`` over the worker threads
and let each worker take rows (or strips) from a shared atomic counter
(:func:`matcher._kernels.intrinsics.fetch_add`).
numba's OpenMP layer splits a ``prange`` statically, so a worker that another process keeps off
its core would otherwise hold up half of the rows; with the counter the other worker takes them.

The other kernel modules of this package share the row helpers (``_census_row``, ``_row_cost``,
``_select_row``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels.intrinsics import fetch_add, popcount64

__all__ = ["COST_SENTINEL", "census_match_kernel", "census_rows_kernel", "cost_volume_kernel"]

#: Cost stored in a uint16 cost volume where ``x - d < 0`` (not a candidate).
COST_SENTINEL = np.uint16(0xFFFF)
_BIG = np.uint32(0xFFFFFFFF)


@njit(cache=True)
def _neighbour_row(padded, offsets, k, r, y, W):  # pragma: no cover - compiled
    """The ``W`` padded pixels at offset ``offsets[k]`` from image row ``y``, columns ``0..W-1``."""
    c = r + offsets[k, 1]
    return padded[y + r + offsets[k, 0], c : c + W]


@njit(cache=True)
def _census_row(padded, offsets, r, y, tmp, out):  # pragma: no cover - compiled
    """Census codes of image row ``y`` into ``out`` (n_words, W) uint64, any numeric dtype.

    Comparisons are made 8 at a time in one pass over ``x`` (8 neighbour rows read together),
    giving one byte per pixel in ``tmp`` (8, W) uint8; the 8 bytes of a word are then packed in
    one more pass. Bit ``k`` of a code (neighbour ``offsets[k]``, 1 iff the centre is brighter)
    is bit ``k % 64`` of word ``k // 64``. The comparisons are exact in the image's own dtype.
    """
    nw, W = out.shape
    n = offsets.shape[0]
    zero8 = np.uint8(0)
    centre = padded[y + r, r : r + W]
    for wi in range(nw):
        k_end = min(n, 64 * wi + 64)
        nb = 0
        for k0 in range(64 * wi, k_end, 8):
            t = tmp[nb]
            nb += 1
            if k0 + 8 <= k_end:
                s0 = _neighbour_row(padded, offsets, k0, r, y, W)
                s1 = _neighbour_row(padded, offsets, k0 + 1, r, y, W)
                s2 = _neighbour_row(padded, offsets, k0 + 2, r, y, W)
                s3 = _neighbour_row(padded, offsets, k0 + 3, r, y, W)
                s4 = _neighbour_row(padded, offsets, k0 + 4, r, y, W)
                s5 = _neighbour_row(padded, offsets, k0 + 5, r, y, W)
                s6 = _neighbour_row(padded, offsets, k0 + 6, r, y, W)
                s7 = _neighbour_row(padded, offsets, k0 + 7, r, y, W)
                for x in range(W):
                    c = centre[x]
                    t[x] = (
                        (np.uint8(1) if c > s0[x] else zero8)
                        | (np.uint8(2) if c > s1[x] else zero8)
                        | (np.uint8(4) if c > s2[x] else zero8)
                        | (np.uint8(8) if c > s3[x] else zero8)
                        | (np.uint8(16) if c > s4[x] else zero8)
                        | (np.uint8(32) if c > s5[x] else zero8)
                        | (np.uint8(64) if c > s6[x] else zero8)
                        | (np.uint8(128) if c > s7[x] else zero8)
                    )
            else:
                for x in range(W):
                    t[x] = zero8
                for k in range(k0, k_end):
                    src = _neighbour_row(padded, offsets, k, r, y, W)
                    bit = np.uint8(1 << (k - k0))
                    for x in range(W):
                        t[x] |= bit if centre[x] > src[x] else zero8
        o = out[wi]
        if nb == 8:
            t0 = tmp[0]
            t1 = tmp[1]
            t2 = tmp[2]
            t3 = tmp[3]
            t4 = tmp[4]
            t5 = tmp[5]
            t6 = tmp[6]
            t7 = tmp[7]
            for x in range(W):
                o[x] = (
                    np.uint64(t0[x])
                    | (np.uint64(t1[x]) << np.uint64(8))
                    | (np.uint64(t2[x]) << np.uint64(16))
                    | (np.uint64(t3[x]) << np.uint64(24))
                    | (np.uint64(t4[x]) << np.uint64(32))
                    | (np.uint64(t5[x]) << np.uint64(40))
                    | (np.uint64(t6[x]) << np.uint64(48))
                    | (np.uint64(t7[x]) << np.uint64(56))
                )
        else:
            t0 = tmp[0]
            for x in range(W):
                o[x] = np.uint64(t0[x])
            for j in range(1, nb):
                tj = tmp[j]
                sh = np.uint64(8 * j)
                for x in range(W):
                    o[x] |= np.uint64(tj[x]) << sh


@njit(parallel=True, cache=True)
def census_rows_kernel(padded, offsets, r, n_threads, counter, out):  # pragma: no cover
    """Census codes of an edge-padded image, rows taken dynamically (:func:`_census_row`).

    padded : (H + 2r, W + 2r) uint8, float32 or float64, the image padded by ``r`` (edge
    replicate). offsets : (n, 2) int64 (dy, dx) in bit order, ``|dy|, |dx| <= r``.
    out : (H, n_words, W) uint64, overwritten.
    n_threads : workers (``numba.get_num_threads()``). counter : (1,) int64 zeros (the next row).
    """
    H, nw, W = out.shape
    for _t in prange(n_threads):
        tmp = np.empty((8, W), np.uint8)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            _census_row(padded, offsets, r, y, tmp, out[y])


@njit(cache=True)
def _row_cost(cl, cr, y, n_disp, buf):  # pragma: no cover - compiled
    """Hamming costs of row ``y`` into ``buf[d, x]`` for ``x >= d`` (other entries untouched)."""
    nw = cl.shape[1]
    W = cl.shape[2]
    for d in range(n_disp):
        n = W - d
        row = buf[d, d:]
        left = cl[y, 0, d:]
        right = cr[y, 0, :n]
        for i in range(n):
            row[i] = np.uint32(popcount64(left[i] ^ right[i]))
        for wi in range(1, nw):
            left = cl[y, wi, d:]
            right = cr[y, wi, :n]
            for i in range(n):
                row[i] += np.uint32(popcount64(left[i] ^ right[i]))


@njit(cache=True)
def _hbox(raw, h, out):  # pragma: no cover - compiled
    """Box sum of width ``2h + 1`` along x of each ``raw[d]`` over its valid segment ``[d, W)``.

    Columns outside the segment are replaced by the nearest valid one (edge replicate).
    """
    D, W = raw.shape
    for d in range(D):
        seg = raw[d, d:]
        o = out[d, d:]
        n = W - d
        s = np.uint32(0)
        for j in range(-h, h + 1):
            s += seg[min(max(j, 0), n - 1)]
        for i in range(n):
            o[i] = s
            s = s - seg[max(i - h, 0)] + seg[min(i + h + 1, n - 1)]


@njit(cache=True)
def _select_row(
    cost, lr_tol, subpix, bestc, bestd, bestcr, bestdr, out
):  # pragma: no cover - compiled
    """WTA (ties -> smallest d), optional LR check and parabola subpixel for one row."""
    D, W = cost.shape
    for x in range(W):
        bestc[x] = _BIG
        bestd[x] = 0
    for d in range(D):
        c = cost[d, d:]
        bc = bestc[d:]
        bd = bestd[d:]
        for i in range(W - d):
            if c[i] < bc[i]:
                bc[i] = c[i]
                bd[i] = d
    if lr_tol >= 0:
        for x in range(W):
            bestcr[x] = _BIG
            bestdr[x] = 0
        for d in range(D):
            c = cost[d, d:]
            for i in range(W - d):
                if c[i] < bestcr[i]:
                    bestcr[i] = c[i]
                    bestdr[i] = d
    for x in range(W):
        d = bestd[x]
        val = np.float64(d)
        if subpix and d > 0 and d < D - 1 and x - d - 1 >= 0:
            cm = np.float64(cost[d - 1, x])
            cp = np.float64(cost[d + 1, x])
            c0 = np.float64(bestc[x])
            den = cm - 2.0 * c0 + cp
            if den > 0.0:
                val += (cm - cp) / (2.0 * den)
        if lr_tol >= 0 and abs(d - bestdr[x - d]) > lr_tol:
            val = np.inf
        out[x] = np.float32(val)


@njit(cache=True)
def _strip_costs(
    pl, pr, offsets, r, y0, y1, n_disp, h, lr_tol, subpix, bufs, out
):  # pragma: no cover - compiled
    """One strip of rows ``[y0, y1)`` of :func:`census_match_kernel` (codes computed here)."""
    tmp, cbl, cbr, raw, hb, agg, bestc, bestd, bestcr, bestdr = bufs
    H = out.shape[0]
    if h == 0:
        for y in range(y0, y1):
            _census_row(pl, offsets, r, y, tmp, cbl[0])
            _census_row(pr, offsets, r, y, tmp, cbr[0])
            _row_cost(cbl, cbr, 0, n_disp, raw[0])
            _select_row(raw[0], lr_tol, subpix, bestc, bestd, bestcr, bestdr, out[y])
        return
    W = out.shape[1]
    m = y1 - y0 + 2 * h
    for j in range(m):
        yy = min(max(y0 - h + j, 0), H - 1)
        _census_row(pl, offsets, r, yy, tmp, cbl[0])
        _census_row(pr, offsets, r, yy, tmp, cbr[0])
        _row_cost(cbl, cbr, 0, n_disp, raw[j])
        _hbox(raw[j], h, hb[j])
    for d in range(n_disp):
        a = agg[d, d:]
        for i in range(W - d):
            a[i] = 0
        for j in range(2 * h + 1):
            src = hb[j, d, d:]
            for i in range(W - d):
                a[i] += src[i]
    _select_row(agg, lr_tol, subpix, bestc, bestd, bestcr, bestdr, out[y0])
    for y in range(y0 + 1, y1):
        j_old = y - y0 - 1
        j_new = y - y0 + 2 * h
        for d in range(n_disp):
            a = agg[d, d:]
            old = hb[j_old, d, d:]
            new = hb[j_new, d, d:]
            for i in range(W - d):
                a[i] = a[i] - old[i] + new[i]
        _select_row(agg, lr_tol, subpix, bestc, bestd, bestcr, bestdr, out[y])


@njit(parallel=True, cache=True)
def census_match_kernel(
    pl, pr, offsets, r, n_disp, h, lr_tol, subpix, strip, n_threads, counter, out
):  # pragma: no cover - compiled
    """Census -> Hamming -> (box aggregation) -> WTA in one parallel region, no code images.

    pl, pr : (H + 2r, W + 2r) edge-padded images (uint8, float32 or float64).
    offsets : (n, 2) int64 census offsets, ``|dy|, |dx| <= r``.
    n_disp : number of candidates D (< W). h : aggregation half-size (0 = per-pixel Hamming).
    lr_tol : LR tolerance, < 0 disables. subpix : parabola refinement. strip : rows per work
    item. n_threads : ``numba.get_num_threads()`` (read by the caller: calling it here would
    stop numba from caching the kernel). counter : (1,) int64 zeros, the shared strip counter.
    out : (H, W) float32, overwritten (inf where the LR check fails).

    Each worker computes the census codes of the rows it needs (the halo rows of aggregation
    are recomputed), so no ``(H, n_words, W)`` code image is written; per strip it follows
    codes -> :func:`_row_cost` -> :func:`_hbox` / vertical box sum -> :func:`_select_row`, the
    same integer arithmetic as ``winner_takes_all(aggregate_cost(cost_volume(...)))``.
    """
    H, W = out.shape
    nw = (offsets.shape[0] + 63) // 64
    n_items = (H + strip - 1) // strip
    nrows = strip + 2 * h if h > 0 else 1
    for _t in prange(n_threads):
        tmp = np.empty((8, W), np.uint8)
        cbl = np.empty((1, nw, W), np.uint64)
        cbr = np.empty((1, nw, W), np.uint64)
        raw = np.empty((nrows, n_disp, W), np.uint32)
        hb = np.empty((nrows, n_disp, W), np.uint32) if h > 0 else raw
        agg = np.empty((n_disp, W), np.uint32) if h > 0 else raw[0]
        bestc = np.empty(W, np.uint32)
        bestd = np.empty(W, np.int64)
        bestcr = np.empty(W, np.uint32)
        bestdr = np.empty(W, np.int64)
        bufs = (tmp, cbl, cbr, raw, hb, agg, bestc, bestd, bestcr, bestdr)
        while True:
            s = fetch_add(counter, 1)
            if s >= n_items:
                break
            y0 = s * strip
            _strip_costs(pl, pr, offsets, r, y0, min(H, y0 + strip), n_disp, h, lr_tol, subpix,
                         bufs, out)


@njit(parallel=True, cache=True)
def cost_volume_kernel(cl, cr, out):  # pragma: no cover - compiled
    """Full (H, D, W) uint16 Hamming cost volume; ``COST_SENTINEL`` where ``x - d < 0``."""
    H, D, W = out.shape
    for y in prange(H):
        row = np.empty((D, W), np.uint32)
        _row_cost(cl, cr, y, D, row)
        for d in range(D):
            o = out[y, d]
            for x in range(min(d, W)):
                o[x] = COST_SENTINEL
            src = row[d, d:]
            od = o[d:]
            for i in range(W - d):
                od[i] = np.uint16(src[i])
