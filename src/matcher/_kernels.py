"""Numba kernels of the census matcher. They trust their input: validate at the public boundary.

Layouts used here (chosen for contiguous, vectorisable inner loops over ``x``):

* census codes: ``(H, n_words, W)`` uint64 ("word-planar"); the public API exposes
  ``(H, W, n_words)``;
* cost rows and volumes: ``(D, W)`` per row, ``(H, D, W)`` per image.

Inner loops index from 0 on sliced views, so every index is provably non-negative and numba's
negative-index wraparound check does not block vectorisation.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import njit, prange, types
from numba.extending import intrinsic

__all__ = [
    "COST_SENTINEL",
    "census_kernel",
    "census_kernel_u8",
    "cost_volume_kernel",
    "fused_match_kernel",
    "popcount64",
]

#: Cost stored in a uint16 cost volume where ``x - d < 0`` (not a candidate).
COST_SENTINEL = np.uint16(0xFFFF)
_BIG = np.uint32(0xFFFFFFFF)


@intrinsic
def popcount64(typingctx, x):  # pragma: no cover - compiled
    """LLVM ``ctpop`` on a uint64 (a ``popcnt`` instruction, or a vector popcount)."""
    sig = types.uint64(types.uint64)

    def codegen(context, builder, signature, args):
        return builder.ctpop(args[0])

    return sig, codegen


@njit(parallel=True, cache=True)
def census_kernel(padded, offsets, r, out):  # pragma: no cover - compiled
    """Census codes of an edge-padded image.

    padded : (H + 2r, W + 2r) float32/float64, the image padded by ``r`` (edge replicate).
    offsets : (n, 2) int64 (dy, dx) in bit order, ``|dy|, |dx| <= r``.
    out : (H, n_words, W) uint64, overwritten. Bit ``k`` is bit ``k % 64`` of word ``k // 64``.
    """
    H, nw, W = out.shape
    n = offsets.shape[0]
    one = np.uint64(1)
    zero = np.uint64(0)
    for y in prange(H):
        centre = padded[y + r, r : r + W]
        for wi in range(nw):
            o = out[y, wi]
            for x in range(W):
                o[x] = zero
        for k in range(n):
            dy = offsets[k, 0]
            dx = offsets[k, 1]
            src = padded[y + r + dy, r + dx : r + dx + W]
            o = out[y, k >> 6]
            b = np.uint64(k & 63)
            for x in range(W):
                o[x] |= (one if centre[x] > src[x] else zero) << b


@njit(parallel=True, cache=True)
def census_kernel_u8(padded, offsets, r, out):  # pragma: no cover - compiled
    """:func:`census_kernel` for uint8 images, 8 bits at a time in uint8 lanes.

    Each group of 8 comparisons is OR-ed into a uint8 accumulator with constant masks (32 lanes
    per AVX2 instruction, no ``uint8 << variable`` promotion), then widened once into its word.
    """
    H, nw, W = out.shape
    n = offsets.shape[0]
    zero64 = np.uint64(0)
    zero8 = np.uint8(0)
    masks = np.array([1, 2, 4, 8, 16, 32, 64, 128], dtype=np.uint8)
    for y in prange(H):
        centre = padded[y + r, r : r + W]
        acc = np.empty(W, np.uint8)
        for wi in range(nw):
            o = out[y, wi]
            for x in range(W):
                o[x] = zero64
        for k0 in range(0, n, 8):
            for x in range(W):
                acc[x] = zero8
            for k in range(k0, min(k0 + 8, n)):
                dy = offsets[k, 0]
                dx = offsets[k, 1]
                src = padded[y + r + dy, r + dx : r + dx + W]
                bit = masks[k - k0]
                for x in range(W):
                    acc[x] |= bit if centre[x] > src[x] else zero8
            o = out[y, k0 >> 6]
            shift = np.uint64(k0 & 63)
            for x in range(W):
                o[x] |= np.uint64(acc[x]) << shift


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


@njit(parallel=True, cache=True)
def fused_match_kernel(cl, cr, n_disp, h, lr_tol, subpix, strip, n_threads, out):  # pragma: no cover
    """Census codes -> Hamming -> (box aggregation) -> WTA, without an (H, D, W) volume.

    cl, cr : (H, n_words, W) uint64 codes. n_disp : number of candidates D (< W).
    h : aggregation half-size (0 = per-pixel Hamming). lr_tol : LR tolerance, < 0 disables.
    subpix : parabola refinement. strip : rows per work item.
    n_threads : ``numba.get_num_threads()`` (read by the caller: calling it here would stop numba
    from caching the kernel); one set of buffers per thread is allocated once, up front.
    out : (H, W) float32, overwritten (inf where the LR check fails).

    Work items are strips of rows; run under ``numba.parallel_chunksize(1)`` so that threads take
    strips dynamically (robust when another process holds a core).
    """
    H = cl.shape[0]
    W = cl.shape[2]
    n_items = (H + strip - 1) // strip
    nrows = strip + 2 * h if h > 0 else 1
    raw_all = np.empty((n_threads, nrows, n_disp, W), np.uint32)
    hb_all = np.empty((n_threads, nrows, n_disp, W), np.uint32) if h > 0 else raw_all
    agg_all = np.empty((n_threads, n_disp, W), np.uint32)
    bestc_all = np.empty((n_threads, W), np.uint32)
    bestd_all = np.empty((n_threads, W), np.int64)
    bestcr_all = np.empty((n_threads, W), np.uint32)
    bestdr_all = np.empty((n_threads, W), np.int64)
    for s in prange(n_items):
        t = numba.get_thread_id()
        raw = raw_all[t]
        hb = hb_all[t]
        agg = agg_all[t]
        bestc = bestc_all[t]
        bestd = bestd_all[t]
        bestcr = bestcr_all[t]
        bestdr = bestdr_all[t]
        y0 = s * strip
        y1 = min(H, y0 + strip)
        if h == 0:
            for y in range(y0, y1):
                _row_cost(cl, cr, y, n_disp, raw[0])
                _select_row(raw[0], lr_tol, subpix, bestc, bestd, bestcr, bestdr, out[y])
            continue
        m = y1 - y0 + 2 * h
        for j in range(m):
            yy = min(max(y0 - h + j, 0), H - 1)
            _row_cost(cl, cr, yy, n_disp, raw[j])
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
