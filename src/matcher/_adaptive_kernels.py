"""Numba kernels of CTHW and AWCT/AWSCT. They trust their input: validate at the public boundary.

Census codes use the word-planar layout ``(H, n_words, W)`` uint64 of :mod:`matcher._kernels`
(contiguous inner loops over ``x``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from matcher._kernels import _census_row, _row_cost, _select_row, fetch_add, popcount64

__all__ = [
    "adaptive_wta_kernel",
    "disparity_to_int",
    "haar_sums_kernel",
    "upsample2_kernel",
    "right_window_map",
    "path_mode_kernel",
    "edge_integral",
    "select_windows_kernel",
]


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
    chosen : (W,) int64 scratch.
    """
    W = out.shape[0]
    K = sizes.shape[0]
    largest = sizes[K - 1]
    for x in range(W):
        run[x] = 0
        chosen[x] = largest
    prev_area = np.int64(1)
    for k in range(K):
        s = sizes[k]
        r = s // 2
        top = integral[pad + y - r, pad - r : pad - r + W]
        bot = integral[pad + y + r + 1, pad - r : pad - r + W]
        top1 = integral[pad + y - r, pad + r + 1 : pad + r + 1 + W]
        bot1 = integral[pad + y + r + 1, pad + r + 1 : pad + r + 1 + W]
        area = np.int64(s) * np.int64(s)
        if k == 0:
            for x in range(W):
                prev[x] = np.int64(bot1[x] - top1[x] - bot[x] + top[x])
        else:
            for x in range(W):
                c = np.int64(bot1[x] - top1[x] - bot[x] + top[x])
                rn = run[x] + 1 if c * prev_area < prev[x] * area else np.int64(0)
                run[x] = rn
                if rn == n_decreases and chosen[x] == largest:
                    chosen[x] = s
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
    for _t in prange(n_threads):
        prev = np.empty(W, np.int64)
        run = np.empty(W, np.int64)
        chosen = np.empty(W, np.int64)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            _window_row(integral, pad, sizes, n_decreases, y, prev, run, chosen, out[y])


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
    (:func:`matcher._kernels._row_cost`). With ``left_only`` (the caller guarantees
    ``bits_r[x - d] >= bits_l[x]`` for every candidate, as ``right_windows="left_pixel"``
    does) the row gets plain costs and WTA, and only the left pixels with a smaller window
    (few, since edges are sparse) are scored again over their own prefix.
    """
    raw, ml, mr, bestc, bestd, bestcr, bestdr = bufs
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
        own = bestcr  # (W,) uint32 scratch: the costs of one pixel's candidates
        one = np.uint64(1)
        tb = np.int64(0)
        tw = np.int64(0)
        for x in range(W):
            b = bits_l[x]
            k = min(D, x + 1)  # candidates of left pixel x
            tb += b * k
            tw += ((b + 63) >> 6) * k
            if b >= total_bits:
                continue
            lo = x - k + 1
            oc = own[:k]
            for j in range(k):
                oc[j] = 0
            for wi in range(nw):
                rem = b - 64 * wi
                if rem <= 0:
                    break
                m = ~np.uint64(0) if rem >= 64 else (one << np.uint64(rem)) - one
                lw = cl[wi, x] & m
                rr = cr[wi, lo : x + 1]
                for j in range(k):
                    oc[j] += np.uint32(popcount64((lw ^ rr[j]) & m))
            best = oc[0]
            for j in range(1, k):
                best = min(best, oc[j])
            j = k - 1  # the smallest d = x - q with the least cost: the largest such j
            while oc[j] != best:
                j -= 1
            out[x] = np.float32(k - 1 - j)
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
    largest window (each row's codes are computed here, as :func:`matcher._kernels._census_row`).
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
    n_total = offsets.shape[0]
    nw = (n_total + 63) // 64
    D = min(n_disp, W)
    for _t in prange(n_threads):
        tmp = np.empty((8, W), np.uint8)
        cl = np.empty((1, nw, W), np.uint64)
        cr = np.empty((1, nw, W), np.uint64)
        bufs = (np.empty((1, D, W), np.uint32), np.empty((nw, W), np.uint64),
                np.empty((nw, W), np.uint64), np.empty(W, np.uint32), np.empty(W, np.int64),
                np.empty(W, np.uint32), np.empty(W, np.int64))
        bl = np.empty(W, np.int64)
        br = np.empty(W, np.int64)
        prev = np.empty(W, np.int64)
        run = np.empty(W, np.int64)
        chosen = np.empty(W, np.int64)
        scratch = np.empty((2, W), np.uint8)
        while True:
            y = fetch_add(counter, 1)
            if y >= H:
                break
            if integral.shape[0] > 0:
                _window_row(integral, pad, sizes, n_decreases, y, prev, run, chosen, wmap_l[y])
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
        # Few array views in the pixel loop: creating one costs reference counting.
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
                # the largest count (a vectorised max), then its first, i.e. smallest, d;
                # nothing counted (all counts <= 0) -> -1
                ch = col_hist[j]
                best_count = np.int32(0)
                for dd in range(n_disp):
                    best_count = max(best_count, row_hist[dd] + ch[dd])
                best = np.int64(-1)
                if best_count > 0:
                    best = np.int64(0)
                    while row_hist[best] + ch[best] != best_count:
                        best += 1
                if own >= 0:
                    row_hist[own] -= own_adj
                out[y, x] = best


@njit(parallel=True, cache=True)
def haar_sums_kernel(grey, ll, hh):  # pragma: no cover - compiled
    """Integer Haar sums of a uint8 image: ``ll = a + b + c + d``, ``hh = a - b - c + d``.

    grey : (H, W) uint8; ll : (ceil(H/2), ceil(W/2)) uint16 and hh : same shape int16,
    overwritten. Odd sides replicate the last row/column, as :func:`matcher.haar.haar2d`;
    the bands of every ``norm`` are these sums times a power of two, so they are exact.
    """
    H, W = grey.shape
    h2, w2 = ll.shape
    for i in prange(h2):
        r0 = grey[2 * i]
        r1 = grey[min(2 * i + 1, H - 1)]
        for j in range(w2):
            j1 = min(2 * j + 1, W - 1)
            a = np.int32(r0[2 * j])
            b = np.int32(r0[j1])
            c = np.int32(r1[2 * j])
            d = np.int32(r1[j1])
            ll[i, j] = np.uint16(a + b + c + d)
            hh[i, j] = np.int16(a - b - c + d)


@njit(parallel=True, cache=True)
def upsample2_kernel(half, out):  # pragma: no cover - compiled
    """``out[y, x] = 2 * half[y // 2, x // 2]`` as float32, ``inf`` where ``half < 0``.

    half : (ceil(H/2), ceil(W/2)) int64; out : (H, W) float32, overwritten.
    """
    H, W = out.shape
    for y in prange(H):
        src = half[y // 2]
        o = out[y]
        for x in range(W):
            v = src[x // 2]
            o[x] = np.float32(2 * v) if v >= 0 else np.float32(np.inf)
