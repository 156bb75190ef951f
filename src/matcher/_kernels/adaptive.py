"""Numba kernels of AWCT/AWSCT (:mod:`matcher.adaptive`). They trust their input: validate at
the public boundary.

Census codes use the word-planar layout ``(H, n_words, W)`` uint64 of
:mod:`matcher._kernels.census` (contiguous inner loops over ``x``), whose row helpers these
kernels share.

One module on purpose: the kernels of one method (window selection and the adaptive WTA) share
their row helpers and their memory layout.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels.census import _census_row, _row_cost, _select_row
from matcher._kernels.intrinsics import fetch_add, popcount64

__all__ = [
    "adaptive_wta_kernel",
    "edge_integral",
    "right_window_map",
    "select_windows_kernel",
]


#: Largest window side whose window selection runs on int32 (``side**4 < 2**31``).
_NARROW_SIDE = 215


@njit(cache=True)
def _integral(edges, pad, integral):  # pragma: no cover - compiled
    """Summed-area table of ``edges``, clamped outside: (H + 1 + 2 pad, W + 1 + 2 pad) int32.

    ``integral[pad + i, pad + j]`` = edge pixels in ``[0, i) x [0, j)`` for ``0 <= i <= H``,
    ``0 <= j <= W``; indices beyond hold the value of the nearest one inside (so a window
    sum read from it counts pixels outside the image as non-edge, with no clamping).
    """
    H, W = edges.shape
    core = integral[pad : pad + H + 1, pad : pad + W + 1]
    for j in range(W + 1):
        core[0, j] = 0
    for i in range(H):
        s = np.int32(0)
        core[i + 1, 0] = 0
        prev = core[i]
        cur = core[i + 1]
        row = edges[i]
        for j in range(W):
            s += np.int32(row[j])
            cur[j + 1] = prev[j + 1] + s
    for i in range(pad, pad + H + 1):
        row = integral[i]
        for j in range(pad):
            row[j] = row[pad]
            row[pad + W + 1 + j] = row[pad + W]
    for i in range(pad):
        integral[i, :] = integral[pad, :]
        integral[pad + H + 1 + i, :] = integral[pad + H, :]


@njit(cache=True)
def _window_row(integral, pad, sizes, n_decreases, y, prev, run, chosen, out):  # pragma: no cover
    """Window sides of image row ``y`` into ``out`` (W,) uint8 (see :func:`select_windows_kernel`).

    integral : clamped summed-area table from :func:`_integral` with ``pad``; prev, run,
    chosen : (W,) scratch of one integer dtype, which also holds the products ``count *
    area`` of the comparisons: int32 (twice the vector width) needs ``largest**4 < 2**31``,
    i.e. a largest side of at most :data:`_NARROW_SIDE`; int64 always works.
    """
    T = prev.dtype.type
    W = out.shape[0]
    K = sizes.shape[0]
    largest = T(sizes[K - 1])
    for x in range(W):
        run[x] = 0
        chosen[x] = largest
    prev_area = T(1)
    for k in range(K):
        s = sizes[k]
        r = s // 2
        top = integral[pad + y - r, pad - r : pad - r + W]
        bot = integral[pad + y + r + 1, pad - r : pad - r + W]
        top1 = integral[pad + y - r, pad + r + 1 : pad + r + 1 + W]
        bot1 = integral[pad + y + r + 1, pad + r + 1 : pad + r + 1 + W]
        area = T(s * s)
        side = T(s)
        if k == 0:
            for x in range(W):
                prev[x] = T(bot1[x] - top1[x] - bot[x] + top[x])
        else:
            for x in range(W):
                c = T(bot1[x] - top1[x] - bot[x] + top[x])
                rn = T(run[x] + 1) if T(c * prev_area) < T(prev[x] * area) else T(0)
                run[x] = rn
                ch = chosen[x]
                chosen[x] = side if (rn == n_decreases) & (ch == largest) else ch
                prev[x] = c
        prev_area = area
    for x in range(W):
        out[x] = np.uint8(chosen[x])


@njit(cache=True)
def edge_integral(edges, largest):  # pragma: no cover - compiled
    """``(integral, pad)`` for :func:`_window_row`: windows up to side ``largest``."""
    H, W = edges.shape
    pad = largest // 2 + 1
    integral = np.empty((H + 1 + 2 * pad, W + 1 + 2 * pad), np.int32)
    _integral(edges, pad, integral)
    return integral, pad


@njit(parallel=True, cache=True)
def select_windows_kernel(edges, sizes, n_decreases, n_threads, counter, out):  # pragma: no cover
    """Per-pixel window choice from edge counts (see :func:`matcher.adaptive.select_windows`).

    edges : (H, W) bool. sizes : (K,) int64 odd window sides, increasing. n_decreases : N >= 1.
    n_threads : workers; counter : (1,) int64 zeros (next row).
    out : (H, W) uint8, overwritten with the chosen side.

    The proportion of window ``k`` is ``count_k / s_k**2`` (pixels outside the image count as
    non-edge). A decrease is ``count_k / s_k**2 < count_{k-1} / s_{k-1}**2``, compared exactly as
    ``count_k * s_{k-1}**2 < count_{k-1} * s_k**2``. The side chosen is the first at which N
    decreases in a row have occurred; if none, the largest. Counts come from a clamped
    summed-area table (4 lookups per window, no bounds logic); each row is processed window
    by window across ``x`` so that the loops vectorise.
    """
    H, W = edges.shape
    integral, pad = edge_integral(edges, sizes[sizes.shape[0] - 1])
    narrow = sizes[sizes.shape[0] - 1] <= _NARROW_SIDE
    for _t in prange(n_threads):
        s32 = np.empty((3, W), np.int32)
        s64 = np.empty((3, W), np.int64)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            if narrow:
                _window_row(integral, pad, sizes, n_decreases, y, s32[0], s32[1], s32[2], out[y])
            else:
                _window_row(integral, pad, sizes, n_decreases, y, s64[0], s64[1], s64[2], out[y])


@njit(cache=True)
def _right_row(row, n_disp, scratch, o):  # pragma: no cover - compiled
    """``o[q] = max(row[q : q + n_disp])`` (van Herk / Gil-Werman, branch-free passes).

    scratch : (2, W) uint8. Blocks of ``n_disp`` pixels: ``g`` is the running maximum from a
    block's start, ``h`` the one from its end; a full window of ``n_disp`` pixels meets at
    most two adjacent blocks, so its maximum is ``max(h[q], g[q + n_disp - 1])``. The windows
    cut by the right border are a running maximum from the row's end.
    """
    W = row.shape[0]
    g = scratch[0]
    h = scratch[1]
    for start in range(0, W, n_disp):
        end = min(start + n_disp, W)
        m = row[start]
        for i in range(start, end):
            m = max(m, row[i])
            g[i] = m
        m = row[end - 1]
        for i in range(end - 1, start - 1, -1):
            m = max(m, row[i])
            h[i] = m
    for q in range(W - n_disp + 1):
        o[q] = max(h[q], g[q + n_disp - 1])
    m = row[W - 1]
    for q in range(W - 1, max(W - n_disp, -1), -1):
        m = max(m, row[q])
        o[q] = m


@njit(cache=True)
def right_window_map(wmap, n_disp, out):  # pragma: no cover - compiled
    """``out[y, q] = max(wmap[y, q : q + n_disp])`` (the window ``"left_pixel"`` needs at ``q``).

    wmap, out : (H, W) uint8. A sliding maximum (:func:`_right_row`), ``O(H W)``.
    """
    H, W = wmap.shape
    scratch = np.empty((2, W), np.uint8)
    for y in range(H):
        _right_row(wmap[y], n_disp, scratch, out[y])


@njit(cache=True)
def _prefix_masks(bits, masks):  # pragma: no cover - compiled
    """``masks[wi, x]``: the bits of word ``wi`` inside the first ``bits[x]`` bits of a code."""
    nw, W = masks.shape
    ones = np.uint64(0xFFFFFFFFFFFFFFFF)
    one = np.uint64(1)
    for wi in range(nw):
        m = masks[wi]
        base = 64 * wi
        for x in range(W):
            rem = bits[x] - base
            if rem >= 64:
                m[x] = ones
            elif rem > 0:
                m[x] = (one << np.uint64(rem)) - one
            else:
                m[x] = np.uint64(0)


@njit(cache=True, inline="always")
def _rescore(cl, cr, x, k, b, acc):  # pragma: no cover - compiled
    """WTA disparity of left pixel ``x`` over its own first ``b`` bits (``0 < b``).

    cl, cr : (nw, W) codes of the row; candidates ``d = 0 .. k - 1`` are the right pixels
    ``q = x - d``, a contiguous run ``[x - k + 1, x]`` (vectorised over it). acc : (>= k,)
    int32 scratch, the candidates' costs in run order ``j = k - 1 - d``. Whole words are
    compared as they are and only the last, partial word is masked. The winner is one
    vectorised minimum of the keys ``cost << sh | (2**sh - 1 - j)`` (``2**sh >= k``): the least
    cost and, among equal costs, the largest ``j``, i.e. the smallest ``d``
    (:func:`_last_argmin_keys`; int32 keys, narrow vectors); if the keys could overflow, a
    minimum and a search instead (:func:`_last_argmin_search`).
    """
    lo = x - k + 1
    full = b >> 6
    rem = b & 63
    a = acc[:k]
    for j in range(k):
        a[j] = 0
    # slices, not 2-D indexing: with a run-time k, these loops vectorise far better
    for wi in range(full):
        lw = cl[wi, x]
        rr = cr[wi, lo : x + 1]
        for j in range(k):
            a[j] += np.int32(popcount64(lw ^ rr[j]))
    if rem:
        m = (np.uint64(1) << np.uint64(rem)) - np.uint64(1)
        lw = cl[full, x] & m
        rr = cr[full, lo : x + 1]
        for j in range(k):
            a[j] += np.int32(popcount64((lw ^ rr[j]) & m))
    if _keys_fit(b, k):
        return k - 1 - _last_argmin_keys(acc, k)
    return k - 1 - _last_argmin_search(acc, k)


@njit(cache=True, inline="always")
def _key_shift(k):  # pragma: no cover - compiled
    """The least ``sh`` with ``2**sh >= k``."""
    sh = 0
    while (1 << sh) < k:
        sh += 1
    return sh


@njit(cache=True, inline="always")
def _keys_fit(max_cost, k):  # pragma: no cover - compiled
    """Whether the int32 keys of :func:`_last_argmin_keys` hold costs up to ``max_cost``."""
    sh = _key_shift(k)
    return (np.int64(max_cost) << sh) + (1 << sh) < 2**31


@njit(cache=True, inline="always")
def _last_argmin_keys(acc, k):  # pragma: no cover - compiled
    """The largest ``j < k`` with ``acc[j] == min(acc[:k])``; acc : int32, ``>= 0``.

    One vectorised minimum of the keys ``acc[j] << sh | (2**sh - 1 - j)`` (``2**sh >= k``),
    which must fit in int32 (:func:`_keys_fit`).
    """
    sh = _key_shift(k)
    low = np.int32((1 << sh) - 1)
    ish = np.int32(sh)
    best = np.int32(0x7FFFFFFF)
    for j in range(k):
        best = min(best, (acc[j] << ish) | (low - np.int32(j)))
    return np.int64(low - (best & low))


@njit(cache=True, inline="always")
def _last_argmin_search(acc, k):  # pragma: no cover - compiled
    """:func:`_last_argmin_keys` for any costs: a minimum, then a search from the end."""
    best = acc[0]
    for j in range(1, k):
        best = min(best, acc[j])
    j = k - 1
    while acc[j] != best:
        j -= 1
    return np.int64(j)


@njit(cache=True)
def _adaptive_row(
    cl3, cr3, bits_l, bits_r, n_disp, total_bits, left_only, bufs, out, totals
):  # pragma: no cover - compiled
    """Hamming cost over the smaller window's prefix + WTA of one row (codes ``(1, nw, W)``).

    The prefix mask of ``min(b_l, b_r)`` bits is the AND of the two pixels' own prefix masks,
    so the cost of a pair is ``sum_wi popcount((L ^ R) & ML & MR)`` with per-pixel masks
    ``ML``, ``MR`` (contiguous, branch-free, vectorised). Codes are zero beyond
    ``total_bits``, so words below the row's smallest code length need no mask at all, and a
    row in which every pixel uses the largest window costs exactly plain census
    (:func:`matcher._kernels.census._row_cost`). With ``left_only`` (the caller guarantees
    ``bits_r[x - d] >= bits_l[x]`` for every candidate, as ``right_windows="left_pixel"``
    does) the row gets plain costs and WTA, and only the left pixels with a smaller window
    (few, since edges are sparse) are scored again over their own prefix.
    """
    raw, ml, mr, bestc, bestd, bestcr, bestdr, keys = bufs
    cl = cl3[0]
    cr = cr3[0]
    nw, W = cl.shape
    D = min(n_disp, W)
    cost = raw[0]
    lowest = total_bits
    for x in range(W):
        lowest = min(lowest, min(bits_l[x], bits_r[x]))
    if lowest >= total_bits:
        _row_cost(cl3, cr3, 0, D, cost)
        n_pairs = np.int64(D) * np.int64(W) - np.int64(D) * np.int64(D - 1) // 2
        tb = n_pairs * total_bits
        tw = n_pairs * ((total_bits + 63) // 64)
    elif left_only:
        # min(bits_l[x], bits_r[x - d]) == bits_l[x] for every candidate: plain costs and WTA
        # for the row; then each left pixel with a smaller window (few: edges are sparse) is
        # scored again over its own prefix, candidates in a contiguous run of right pixels
        # q = x - d (vectorised), and its WTA result replaces the plain one
        _row_cost(cl3, cr3, 0, D, cost)
        _select_row(cost[:D], -1, False, bestc, bestd, bestcr, bestdr, out)
        tb = np.int64(0)
        tw = np.int64(0)
        for x in range(W):
            b = bits_l[x]
            k = min(D, x + 1)  # candidates of left pixel x
            tb += b * k
            tw += ((b + 63) >> 6) * k
            if b < total_bits:
                out[x] = np.float32(_rescore(cl, cr, x, k, b, keys))
        totals[0] = tb
        totals[1] = tw
        return
    else:
        plain = lowest // 64  # words every pair of this row compares in full
        _prefix_masks(bits_l, ml)
        _prefix_masks(bits_r, mr)
        tb = np.int64(0)
        tw = np.int64(0)
        for d in range(D):
            bll = bits_l[d:]
            for i in range(W - d):
                b = min(bll[i], bits_r[i])
                tb += b
                tw += (b + 63) >> 6
        for d in range(D):
            n = W - d
            c = cost[d, d:]
            for i in range(n):
                c[i] = 0
            for wi in range(plain):
                left = cl[wi, d:]
                right = cr[wi, :n]
                for i in range(n):
                    c[i] += np.uint32(popcount64(left[i] ^ right[i]))
            for wi in range(plain, nw):
                left = cl[wi, d:]
                right = cr[wi, :n]
                mleft = ml[wi, d:]
                mright = mr[wi, :n]
                for i in range(n):
                    c[i] += np.uint32(popcount64((left[i] ^ right[i]) & mleft[i] & mright[i]))
    _select_row(cost[:D], -1, False, bestc, bestd, bestcr, bestdr, out)
    totals[0] = tb
    totals[1] = tw


@njit(parallel=True, cache=True)
def adaptive_wta_kernel(
    pl, pr, offsets, r, wmap_l, wmap_r, bits_of, n_disp, left_only, integral, pad, sizes,
    n_decreases, right_mode, n_threads, counter, out, totals
):  # pragma: no cover - compiled
    """Census codes + Hamming cost over the smaller window's prefix + winner-takes-all, fused.

    pl, pr : (H + 2r, W + 2r) edge-padded images; offsets : (n, 2) int64 census offsets of the
    largest window (each row's codes are computed here, as
    :func:`matcher._kernels.census._census_row`).
    wmap_l, wmap_r : (H, W) uint8 window sides; bits_of : (max side + 1,) int64, the code
    length (a prefix, ``<= n``) of each side, so ``bits_l = bits_of[wmap_l]`` and likewise
    ``bits_r``. The cost of ``(y, x, d)`` is the number of differing bits among the first
    ``min(bits_l[y, x], bits_r[y, x - d])`` bits. left_only : the caller guarantees
    ``bits_r[y, x - d] >= bits_l[y, x]`` for every candidate (``"left_pixel"``), which skips
    the right masks; the costs are the same.
    integral, pad, sizes, n_decreases : if ``integral`` is not empty, the window sides are
    chosen here, row by row, into ``wmap_l`` (an output then; :func:`edge_integral`,
    :func:`_window_row`); otherwise ``wmap_l`` is an input. right_mode : 0 = ``wmap_r`` is an
    input; 1 = it is written here as the sliding maximum of ``wmap_l`` over ``n_disp``
    (:func:`right_window_map`); 2 = a copy of ``wmap_l``. Candidates: ``0 <= d < n_disp`` with
    ``x - d >= 0``; ties go to the smallest ``d``.
    n_threads : workers; counter : (1,) int64 zeros (next row).
    out : (H, W) float32, overwritten with the integer disparity.
    totals : (H, 4) int64, overwritten: per row, the bits compared, the 64-bit words touched
    (``ceil(bits / 64)`` per pixel and candidate), and the census bits of the left and of
    the right row (``sum bits_l[y]``, ``sum bits_r[y]``).
    """
    H, W = out.shape
    narrow = sizes[sizes.shape[0] - 1] <= _NARROW_SIDE
    n_total = offsets.shape[0]
    nw = (n_total + 63) // 64
    D = min(n_disp, W)
    for _t in prange(n_threads):
        tmp = np.empty((8, W), np.uint8)
        cl = np.empty((1, nw, W), np.uint64)
        cr = np.empty((1, nw, W), np.uint64)
        bufs = (np.empty((1, D, W), np.uint32), np.empty((nw, W), np.uint64),
                np.empty((nw, W), np.uint64), np.empty(W, np.uint32), np.empty(W, np.int64),
                np.empty(W, np.uint32), np.empty(W, np.int64), np.empty(D, np.int32))
        bl = np.empty(W, np.int64)
        br = np.empty(W, np.int64)
        s32 = np.empty((3, W), np.int32)
        s64 = np.empty((3, W), np.int64)
        scratch = np.empty((2, W), np.uint8)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            if integral.shape[0] > 0 and narrow:
                _window_row(integral, pad, sizes, n_decreases, y, s32[0], s32[1], s32[2], wmap_l[y])
            elif integral.shape[0] > 0:
                _window_row(integral, pad, sizes, n_decreases, y, s64[0], s64[1], s64[2], wmap_l[y])
            if right_mode == 1:
                _right_row(wmap_l[y], n_disp, scratch, wmap_r[y])
            elif right_mode == 2:
                wmap_r[y, :] = wmap_l[y, :]
            _census_row(pl, offsets, r, y, tmp, cl[0])
            _census_row(pr, offsets, r, y, tmp, cr[0])
            sl = np.int64(0)
            sr = np.int64(0)
            wl = wmap_l[y]
            wr = wmap_r[y]
            for x in range(W):
                bl[x] = bits_of[wl[x]]
                br[x] = bits_of[wr[x]]
                sl += bl[x]
                sr += br[x]
            _adaptive_row(cl, cr, bl, br, n_disp, n_total, left_only, bufs, out[y], totals[y])
            totals[y, 2] = sl
            totals[y, 3] = sr
