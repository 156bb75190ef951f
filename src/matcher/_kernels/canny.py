"""Numba port of the last stage of ``cv2.Canny(dx, dy, low, high, L2gradient=True)``.

Non-maximum suppression and hysteresis on given int16 derivatives, bit-identical to OpenCV's
(``imgproc/src/canny.cpp``; checked against ``cv2.Canny`` in ``tests/matcher``). OpenCV runs
this stage mostly on one thread (hysteresis follows one stack); here the suppression and a
first hysteresis pass run in parallel strips, and one short sequential pass joins the strips.

The rule, as OpenCV's (integer arithmetic of C ``int``, which the kernel reproduces):

* magnitude ``m = dx**2 + dy**2`` (int32), 0 outside the image;
* direction by ``|dy| * 2**15`` against ``|dx| * TG22`` (``tan 22.5 deg`` in Q15) and
  ``|dx| * (TG22 + 2**16)`` (``tan 67.5 deg``): horizontal, vertical or one of the diagonals
  (the diagonal's sign from ``dx ^ dy``);
* a pixel is a candidate iff ``m > low`` and ``m`` beats its two neighbours along that
  direction (``>`` the one before, ``>=`` the one after; ``>`` both on a diagonal);
* strong iff also ``m > high``; the edges are the candidates 8-connected to a strong one.

They trust their input: validate at the public boundary.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from matcher._kernels.intrinsics import fetch_add

__all__ = ["canny_from_derivatives", "canny_on_derivatives", "canny_thresholds"]

#: ``tan(22.5 deg)`` in Q15, as OpenCV's ``TG22``.
_TG22 = int(0.4142135623730950488016887242097 * (1 << 15) + 0.5)


def canny_thresholds(low: float, high: float) -> tuple[int, int]:
    """OpenCV's integer thresholds of squared L2 magnitudes: ``floor(min(t, 32767) ** 2)``.

    Examples
    --------
    >>> canny_thresholds(204.0, 408.0)
    (41616, 166464)
    """
    if low > high:
        low, high = high, low
    out = []
    for t in (low, high):
        t = min(32767.0, t)
        if t > 0:
            t *= t
        out.append(math.floor(t))
    return out[0], out[1]


@njit(cache=True, inline="always")
def _i32(v):  # pragma: no cover - compiled
    """C ``int`` wrap-around of an int64 value."""
    return np.int32(v)


@njit(cache=True)
def _mag_row(dx, dy, y, out):  # pragma: no cover - compiled
    """Squared L2 magnitudes of row ``y`` into ``out[1 : W + 1]`` (0 if ``y`` is outside)."""
    W = dx.shape[1]
    if y < 0 or y >= dx.shape[0]:
        for j in range(W + 2):
            out[j] = 0
        return
    a = dx[y]
    b = dy[y]
    o = out[1 : W + 1]
    for j in range(W):
        u = np.int32(a[j])
        v = np.int32(b[j])
        o[j] = _i32(_i32(u * u) + _i32(v * v))
    out[0] = 0
    out[W + 1] = 0


@njit(cache=True)
def _nms_row(dx, dy, y, mp, mc, mn, low, high, out):  # pragma: no cover - compiled
    """Map row ``y``: 1 = not an edge, 0 = candidate, 2 = strong; ``out`` (W,) uint8.

    mp, mc, mn : (W + 2,) magnitudes of rows ``y - 1``, ``y``, ``y + 1`` (zero-padded).
    Branch-free and on contiguous slices (vectorised): the diagonal's two neighbours are
    picked by a select, not by an index.
    """
    W = dx.shape[1]
    a = dx[y]
    b = dy[y]
    p0 = mp[0:W]
    p1 = mp[1 : W + 1]
    p2 = mp[2 : W + 2]
    c0 = mc[0:W]
    c1 = mc[1 : W + 1]
    c2 = mc[2 : W + 2]
    n0 = mn[0:W]
    n1 = mn[1 : W + 1]
    n2 = mn[2 : W + 2]
    for j in range(W):
        m = c1[j]
        xs = np.int32(a[j])
        ys = np.int32(b[j])
        ax = abs(xs)
        ay = _i32(abs(ys) << 15)
        tg22x = _i32(ax * _TG22)
        tg67x = _i32(tg22x + _i32(ax << 16))
        ok_h = (m > c0[j]) & (m >= c2[j])
        ok_v = (m > p1[j]) & (m >= n1[j])
        # s = -1 when dx, dy have opposite signs: neighbours p[j + 1 - s], n[j + 1 + s]
        ok_neg = (m > p2[j]) & (m > n0[j])
        ok_pos = (m > p0[j]) & (m > n2[j])
        ok_d = ok_neg if (xs ^ ys) < 0 else ok_pos
        ok = ok_h if ay < tg22x else (ok_v if ay > tg67x else ok_d)
        cand = np.int32(ok & (m > low))
        strong = np.int32(m > high)
        out[j] = np.uint8(cand * (2 * strong - 1) + 1)


@njit(cache=True)
def _grow(emap, step, stack, top, lo, hi):  # pragma: no cover - compiled
    """Grow strong pixels (2) into 8-connected candidates (0) of ``emap`` (flat, row ``step``).

    ``stack[:top]`` holds flat indices to grow from (capacity: one more than the pixels that
    can be entered); only indices in ``[lo, hi)`` are read or written, so strips can grow in
    parallel. The padded border (value 1) stops every walk at the image's edge. Branch-free
    pushes: a neighbour's index is written to the stack whatever it holds, and the stack top
    moves only if it was a candidate.
    """
    while top > 0:
        top -= 1
        p = stack[top]
        for q in (p - 1, p + 1, p - step - 1, p - step, p - step + 1,
                  p + step - 1, p + step, p + step + 1):
            inside = (q >= lo) & (q < hi)
            qq = q if inside else p  # p holds 2: never entered again
            v = emap[qq]
            enter = v == 0
            emap[qq] = v | (np.uint8(enter) << np.uint8(1))
            stack[top] = qq
            top += np.int64(enter)


@njit(cache=True)
def _seeds(emap, step, y0, y1, ylo, yhi, stack, top):  # pragma: no cover - compiled
    """Push the strong pixels of image rows ``[y0, y1)`` that have a candidate neighbour.

    Only rows ``[ylo, yhi)`` are read (a strip's own rows; neighbours outside count as
    non-candidates). A strong pixel without a candidate neighbour has nothing to grow into, so
    most strong pixels (edges are mostly strong) never reach the stack. Returns the new top.
    """
    W = step - 2
    for y in range(y0, y1):
        base = (y + 1) * step
        cur = emap[base : base + step]
        up = emap[base - step : base] if y - 1 >= ylo else emap[base : base + step]
        down = emap[base + step : base + 2 * step] if y + 1 < yhi else emap[base : base + step]
        # rows outside [ylo, yhi) are replaced by the pixel's own row: its values there are
        # the pixel and its row neighbours, already counted, so the minimum is unchanged
        for j in range(W):
            m = min(cur[j], cur[j + 2])
            m = min(m, min(up[j], min(up[j + 1], up[j + 2])))
            m = min(m, min(down[j], min(down[j + 1], down[j + 2])))
            stack[top] = base + j + 1
            top += np.int64((cur[j + 1] == 2) & (m == 0))
    return top


@njit(parallel=True, cache=True)
def canny_from_derivatives(dx, dy, low, high, strip, n_threads, counter, out):  # pragma: no cover
    """Canny edges from int16 derivatives, as ``cv2.Canny(dx, dy, ..., L2gradient=True) > 0``.

    dx, dy : (H, W) int16. low, high : integer thresholds of the squared magnitude
    (:func:`canny_thresholds`). strip : rows per work item. n_threads : workers; counter :
    (1,) int64 zeros (next strip). out : (H, W) bool, overwritten; its outermost rows and
    columns are cleared afterwards (as :func:`matcher.edges.canny_edges` wants).

    Each strip computes its map rows and grows its strong pixels inside the strip; a
    sequential pass then grows again from every strong pixel of the strips' first and last
    rows without limits, which reaches what crosses strip borders. The result is the set of
    candidates 8-connected to a strong pixel, whatever the order.
    """
    H, W = dx.shape
    step = W + 2
    emap = np.empty((H + 2) * step, np.uint8)
    emap[:step] = 1
    emap[(H + 1) * step:] = 1
    n_items = (H + strip - 1) // strip
    for _t in prange(n_threads):
        mags = np.empty((3, W + 2), np.int32)
        stack = np.empty(strip * W + 8, np.int64)
        while True:
            s = fetch_add(counter, 1)
            if s >= n_items:
                break
            y0 = s * strip
            y1 = min(H, y0 + strip)
            _mag_row(dx, dy, y0 - 1, mags[0])
            _mag_row(dx, dy, y0, mags[1])
            for y in range(y0, y1):
                _mag_row(dx, dy, y + 1, mags[(y - y0 + 2) % 3])
                base = (y + 1) * step
                row = emap[base : base + step]
                row[0] = 1
                row[step - 1] = 1
                _nms_row(dx, dy, y, mags[(y - y0) % 3], mags[(y - y0 + 1) % 3],
                         mags[(y - y0 + 2) % 3], low, high, row[1 : W + 1])
            top = _seeds(emap, step, y0, y1, y0, y1, stack, 0)
            _grow(emap, step, stack, top, (y0 + 1) * step, (y1 + 1) * step)
    # join the strips: grow from the strong pixels of every strip's first and last row
    stack = np.empty(H * W + 8, np.int64)
    top = 0
    for s in range(n_items):
        y0 = s * strip
        y1 = min(H, y0 + strip)
        top = _seeds(emap, step, y0, y0 + 1, 0, H, stack, top)
        if y1 - 1 > y0:
            top = _seeds(emap, step, y1 - 1, y1, 0, H, stack, top)
    _grow(emap, step, stack, top, 0, emap.shape[0])
    for y in prange(H):
        base = (y + 1) * step + 1
        o = out[y]
        for j in range(W):
            o[j] = emap[base + j] == 2


def canny_on_derivatives(dx: np.ndarray, dy: np.ndarray, low: float, high: float, *,
                         strip: int | None = None) -> np.ndarray:
    """``cv2.Canny(dx, dy, low, high, L2gradient=True) > 0``, bit for bit.

    ``dx``, ``dy``: (H, W) int16 C-contiguous derivatives; ``low``, ``high``: OpenCV's float
    thresholds on the L2 magnitude. ``strip`` rows per parallel strip (default: four strips
    per numba thread, at least 16 rows); the result does not depend on it.

    Examples
    --------
    >>> dx = np.zeros((5, 6), np.int16); dx[:, 3] = 400  # a vertical step
    >>> canny_on_derivatives(dx, np.zeros_like(dx), 100.0, 200.0)[2].astype(int).tolist()
    [0, 0, 0, 1, 0, 0]
    """
    low_i, high_i = canny_thresholds(low, high)
    n_threads = numba.get_num_threads()
    if strip is None:
        strip = max(16, -(-dx.shape[0] // (4 * n_threads)))
    out = np.empty(dx.shape, dtype=np.bool_)
    canny_from_derivatives(dx, dy, low_i, high_i, strip, n_threads, np.zeros(1, np.int64), out)
    return out
