"""Census transform with Haar wavelet (CTHW), the seed paper's §3.1 and Fig. 2-3.

Pipeline (every choice the paper leaves open is a keyword argument, defaults in brackets):

1. One Haar level of both views (:func:`matcher.haar.haar2d`, ``norm`` ["orthonormal"]; the
   census of ``LL`` does not depend on the scale).
2. Census + Hamming + winner-takes-all on the two ``LL`` bands (half resolution), as
   :func:`matcher.match` does with ``method="ct"`` (or ``"sct"`` with ``pattern="sparse"``),
   window ``window`` on the half-resolution grid, ``ceil(D / 2)`` candidates.
3. The left ``HH`` band is binarised: a pixel is an *edge* when ``|HH| > hh_threshold``, with
   ``HH`` measured on the ``"average"`` scale (``(a - b - c + d) / 4`` of the 2 x 2 block, in
   grey levels of the input) whatever ``norm`` is, so the threshold means the same for both
   norms [4.0 grey levels]; ``hh_relative=True`` makes it a fraction of ``max |HH|`` instead.
4. Path search (:func:`modify_disparity`): from every half-resolution pixel, walk left, right,
   up and down until the first edge pixel [not counted; ``include_edge``] or the image border
   (or ``max_path`` steps), and count the coarse disparities met, plus the pixel's own
   [``include_self=True``]. The modified disparity is the most frequent one; ties go to the
   smallest disparity. The paper says both "the largest disparity that appears in the search
   paths" and "the disparity value with the largest number"; we read both as the most frequent
   value (the mode), which is what a vote over the paths means.
5. Back to full resolution: nearest-neighbour upsampling (each coarse pixel covers its 2 x 2
   block; a replicate-padded odd row/column is cropped) and disparity x 2 (even values only).

Operation counts (:class:`matcher.result.OpCounts`) are those of the half-resolution census
match; ``params["ct_ops"]`` holds full-resolution CT's at the same window for comparison.
"""

from __future__ import annotations

import functools
import numbers
import types
from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np

from matcher._kernels import (
    census_match_kernel,
    disparity_range,
    haar_padded_kernel,
    key_shift,
    path_mode_up_kernel,
)
from matcher._validation import (
    check_bool,
    check_image,
    check_max_disparity,
    check_real,
    check_same_shape,
    check_window,
)
from matcher.census import census_disparity
from matcher.haar import HAAR_NORMS, haar2d
from matcher.patterns import n_bits, resolve_offsets
from matcher.result import MatchResult, OpCounts, census_ops

__all__ = ["CTHWResult", "HH_THRESHOLD", "hh_edges", "match_cthw", "modify_disparity"]

#: Default HH binarisation threshold, grey levels on the "average" scale.
HH_THRESHOLD = 4.0
#: Rows per work item of the half-resolution census kernel (as :func:`matcher.match`).
_COARSE_ROWS_PER_ITEM = 2


@dataclass(frozen=True)
class CTHWResult(MatchResult):
    """:class:`matcher.result.MatchResult` of :func:`match_cthw`, with the intermediate maps.

    Attributes
    ----------
    coarse : (ceil(H / 2), ceil(W / 2)) float32 array
        Half-resolution disparity of the ``LL`` match before the path search (``LL`` pixels).
    hh_edges : (ceil(H / 2), ceil(W / 2)) bool array
        The binarised left ``HH`` band (the stop points of the path search).
    """

    coarse: np.ndarray
    hh_edges: np.ndarray


def _check_max_path(max_path: object) -> int:
    if max_path is None:
        return np.iinfo(np.int64).max
    if isinstance(max_path, (bool, np.bool_)) or not isinstance(max_path, numbers.Integral):
        raise TypeError(f"max_path: expected None or an integer >= 1, got {max_path!r}")
    if int(max_path) < 1:
        raise ValueError(
            f"max_path: expected None (walk to the edge or border) or an integer >= 1, "
            f"got {max_path}"
        )
    return int(max_path)


def hh_edges(hh: np.ndarray, *, threshold: float = HH_THRESHOLD, relative: bool = False) -> np.ndarray:
    """Binarise an ``HH`` band: ``|hh| > threshold`` (or ``> threshold * max |hh|``).

    Parameters
    ----------
    hh : (h, w) float array
        The band, on the scale the threshold is meant for.
    threshold : float, default 4.0
        Absolute threshold (``relative=False``) or a fraction of ``max |hh|`` in ``[0, 1]``.
    relative : bool, default False

    Returns
    -------
    (h, w) bool array

    Examples
    --------
    >>> import numpy as np
    >>> hh_edges(np.array([[0.0, -5.0, 3.0]]), threshold=4.0).tolist()
    [[False, True, False]]
    >>> hh_edges(np.array([[0.0, -5.0, 3.0]]), threshold=0.5, relative=True).tolist()
    [[False, True, True]]
    """
    t = check_real(threshold, "threshold", lo=0.0)
    relative = check_bool(relative, "relative")
    a = np.abs(np.asarray(hh, dtype=np.float64))
    if relative:
        if t > 1.0:
            raise ValueError(
                f"threshold: expected a fraction of max |HH| in [0, 1] with relative=True, got {t}"
            )
        t = t * float(a.max()) if a.size else 0.0
    return a > t


def modify_disparity(
    disparity: np.ndarray,
    edges: np.ndarray,
    *,
    include_edge: bool = False,
    include_self: bool = True,
    max_path: int | None = None,
) -> np.ndarray:
    """CTHW's path search: the mode of the disparities on four straight paths (paper Fig. 3).

    Parameters
    ----------
    disparity : (H, W) float array
        Integer-valued disparities ``>= 0``; ``inf``/NaN are invalid and never counted.
    edges : (H, W) bool array
        Stop points of the paths.
    include_edge : bool, default False
        Count the disparity of the edge pixel that stops a path.
    include_self : bool, default True
        Count the pixel's own disparity (once).
    max_path : int or None, default None
        At most this many pixels per direction (``None``: until an edge or the border).

    Returns
    -------
    (H, W) float32 array
        The most frequent disparity among the counted ones (ties -> the smallest); ``inf``
        where nothing valid was counted.

    Examples
    --------
    >>> import numpy as np
    >>> d = np.array([[1, 1, 5, 2, 2, 2]], np.float32)
    >>> e = np.array([[False, False, True, False, False, False]])
    >>> modify_disparity(d, e).tolist()  # the edge pixel itself sees both sides: 2 wins 3 to 2
    [[1.0, 1.0, 2.0, 2.0, 2.0, 2.0]]
    """
    if not isinstance(disparity, np.ndarray) or disparity.ndim != 2:
        raise ValueError(f"disparity: expected an (H, W) array, got {type(disparity).__name__}")
    if not isinstance(edges, np.ndarray) or edges.dtype != np.bool_ or edges.shape != disparity.shape:
        raise ValueError(
            f"edges: expected a bool array of shape {disparity.shape}, got "
            f"{getattr(edges, 'shape', None)} {getattr(edges, 'dtype', type(edges).__name__)}; "
            "binarise it with hh_edges"
        )
    include_edge = check_bool(include_edge, "include_edge")
    include_self = check_bool(include_self, "include_self")
    steps = _check_max_path(max_path)
    d = disparity if disparity.dtype in (np.float32, np.float64) else disparity.astype(np.float64)
    ok, largest = disparity_range(d)
    if not ok:
        raise ValueError(
            "disparity: expected integer-valued disparities >= 0 (inf = invalid); "
            "round a subpixel map first"
        )
    if largest >= 2**31 - 1:
        raise ValueError(f"disparity: expected values below 2**31 - 1, got {largest}")
    out = np.empty(d.shape, dtype=np.float32)
    _path_mode_into(
        d, edges, int(largest) + 1 if largest >= 0 else 1, out, include_edge=include_edge,
        include_self=include_self, steps=steps, up=1,
    )
    return out


def _path_mode_into(
    disparity: np.ndarray,
    edges: np.ndarray,
    n_disp: int,
    out: np.ndarray,
    *,
    include_edge: bool,
    include_self: bool,
    steps: int,
    up: int,
) -> None:
    """The path search on validated input, written into ``out`` upsampled ``up`` times.

    ``disparity`` : (H, W) float32/float64 integers in ``[0, n_disp)``, non-finite = invalid;
    ``out`` : float32, ``up`` times the mode (``inf`` for none) in each ``up x up`` cell,
    cropped to ``out``'s shape (:func:`matcher._kernels.cthw.path_mode_up_kernel`).
    """
    h, w = disparity.shape
    steps = min(steps, h + w)  # no path is longer; keeps index math small
    sh = key_shift(n_disp)
    # vote keys: count << sh | (2**sh - 1 - d); int32 unless the counts could overflow it
    key_dtype = np.int32 if (h + w + 2) << sh < 2**31 else np.int64
    block = max(16, -(-w // numba.get_num_threads()))  # one block per worker
    path_mode_up_kernel(
        disparity, np.ascontiguousarray(edges), n_disp, sh, include_edge, include_self, steps,
        block, up, np.empty(0, key_dtype), out,
    )


@functools.lru_cache(maxsize=32)
def _census_tables(window: int, pattern: str) -> tuple[np.ndarray, int]:
    """``(offsets, n_bits)`` of a census window, cached (read-only offsets)."""
    offsets = resolve_offsets(window, pattern).copy()
    offsets.flags.writeable = False
    return offsets, n_bits(window, pattern)


def _coarse_uint8(
    grey_l: np.ndarray, grey_r: np.ndarray, *, window: int, d_half: int, pattern: str,
    threshold: float,
) -> tuple[np.ndarray, OpCounts, np.ndarray, np.ndarray]:
    """Half-resolution match of uint8 views on integer Haar sums (exact, faster).

    ``LL`` of either norm is a positive power-of-two multiple of the 2 x 2 sum, so the census
    of the integer sums (uint16, 0..1020) is bit-identical to that of the float ``LL`` band,
    and it runs on the integer kernel path. Returns the coarse disparity (as
    :func:`matcher.match`), its operation counts, the integer ``HH`` sums of the left
    view (4 x the ``"average"`` scale) and, if ``threshold >= 0``, its edges
    (:func:`hh_edges` with that absolute threshold; otherwise the array is not filled).
    """
    h2, w2 = (grey_l.shape[0] + 1) // 2, (grey_l.shape[1] + 1) // 2
    r = window // 2
    pl = np.empty((h2 + 2 * r, w2 + 2 * r), np.uint16)
    pr = np.empty_like(pl)
    hh_l = np.empty((h2, w2), np.int16)
    edges = np.empty((h2, w2), np.bool_)
    haar_padded_kernel(
        np.ascontiguousarray(grey_l), np.ascontiguousarray(grey_r), r, threshold, pl, pr, hh_l,
        edges,
    )
    offsets, bits = _census_tables(window, pattern)
    disp = np.empty((h2, w2), dtype=np.float32)
    census_match_kernel(
        pl, pr, offsets, r, d_half, 0, -1, False, _COARSE_ROWS_PER_ITEM,
        numba.get_num_threads(), np.zeros(1, np.int64), disp,
    )
    ops = census_ops((h2, w2), bits, d_half)
    return disp, ops, hh_l, edges


def match_cthw(
    left: np.ndarray,
    right: np.ndarray,
    *,
    window: int = 9,
    max_disparity: int = 64,
    hh_threshold: float = HH_THRESHOLD,
    hh_relative: bool = False,
    norm: Literal["orthonormal", "average"] = "orthonormal",
    pattern: Literal["dense", "sparse"] = "dense",
    include_edge: bool = False,
    include_self: bool = True,
    max_path: int | None = None,
) -> CTHWResult:
    """Census transform with Haar wavelet (CTHW).

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) uint8, integer or float arrays
        Rectified views, same shape; RGB is converted to grey (BT.601).
    window : int, default 9
        Odd census window side on the half-resolution ``LL`` band, ``3 <= window <=
        min(ceil(H / 2), ceil(W / 2))``.
    max_disparity : int, default 64
        Full-resolution candidates ``D`` (``0 .. D - 1``); the ``LL`` match searches
        ``ceil(D / 2)`` half-resolution candidates, so the result is one of ``0, 2, ..``.
    hh_threshold : float, default 4.0
        ``HH`` edge threshold, grey levels of the input on the ``"average"`` scale
        (``|a - b - c + d| / 4 > hh_threshold``); a fraction of ``max |HH|`` when
        ``hh_relative``.
    hh_relative : bool, default False
    norm : {"orthonormal", "average"}, default "orthonormal"
        Haar scaling (:func:`matcher.haar.haar2d`); does not change the result.
    pattern : {"dense", "sparse"}, default "dense"
        Census pattern of the ``LL`` match (``"sparse"``: :func:`matcher.patterns.sparse_pattern`).
    include_edge, include_self, max_path
        Path-search rules, see :func:`modify_disparity`.

    Returns
    -------
    CTHWResult
        ``disparity`` (H, W) float32 (even integers; ``inf`` where invalid), ``ops`` of the
        half-resolution match, ``method="cthw"``, ``params`` with every setting and
        ``params["ct_ops"]``, full-resolution CT's counts; plus ``coarse`` and ``hh_edges``.

    References
    ----------
    Liaw et al., "Improving Census Transform by High-Pass with Haar Wavelet Transform and Edge
    Detection", Sensors 20(9):2537, 2020, §3.1.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (32, 64), dtype=np.uint8)
    >>> left = np.roll(right, 6, axis=1)
    >>> res = match_cthw(left, right, window=5, max_disparity=16)
    >>> float(np.median(res.disparity[:, 16:])), res.disparity.shape
    (6.0, (32, 64))
    """
    grey_l = check_image(left, "left")
    grey_r = check_image(right, "right")
    check_same_shape(grey_l, grey_r)
    h, w = grey_l.shape
    if norm not in HAAR_NORMS:
        raise ValueError(f"norm: expected one of {sorted(HAAR_NORMS)}, got {norm!r}")
    if pattern not in ("dense", "sparse"):
        raise ValueError(f"pattern: expected 'dense' or 'sparse', got {pattern!r}")
    h2, w2 = (h + 1) // 2, (w + 1) // 2
    if min(h2, w2) < 3:
        raise ValueError(
            f"left: expected an image of at least 5 x 5 (its half-resolution LL band must hold a "
            f"3 x 3 window), got shape {(h, w)}"
        )
    window = check_window(window, "window", image_shape=(h2, w2))
    d_full = check_max_disparity(max_disparity, w)
    d_half = -(-d_full // 2)
    if d_half >= w2:
        raise ValueError(
            f"max_disparity: expected ceil(D / 2) < {w2} (the LL band's width), got D = {d_full}"
        )
    hh_threshold = check_real(hh_threshold, "hh_threshold", lo=0.0)
    hh_relative = check_bool(hh_relative, "hh_relative")
    include_edge = check_bool(include_edge, "include_edge")
    include_self = check_bool(include_self, "include_self")
    _check_max_path(max_path)

    if grey_l.dtype == np.uint8 and grey_r.dtype == np.uint8:
        coarse_disp, coarse_ops, hh_sum, edges = _coarse_uint8(
            grey_l, grey_r, window=window, d_half=d_half, pattern=pattern,
            threshold=-1.0 if hh_relative else hh_threshold,
        )
        if hh_relative:
            edges = hh_edges(hh_sum * 0.25, threshold=hh_threshold, relative=True)
    else:
        bands_l = haar2d(grey_l, norm=norm)
        bands_r = haar2d(grey_r, norm=norm)
        coarse_disp = census_disparity(
            bands_l.ll, bands_r.ll, resolve_offsets(window, pattern), window=window,
            max_disparity=d_half,
        )
        coarse_ops = census_ops((h2, w2), n_bits(window, pattern), d_half)
        hh_avg = bands_l.hh * (HAAR_NORMS["average"] / HAAR_NORMS[norm])
        edges = hh_edges(hh_avg, threshold=hh_threshold, relative=hh_relative)
    # path search and nearest-neighbour upsampling (disparity x 2) in one kernel; the coarse
    # map holds the WTA disparities 0 .. d_half - 1
    full = np.empty((h, w), dtype=np.float32)
    _path_mode_into(
        coarse_disp, edges, d_half, full, include_edge=include_edge, include_self=include_self,
        steps=_check_max_path(max_path), up=2,
    )
    bits = _census_tables(window, pattern)[1]
    ct_ops = census_ops((h, w), bits, d_full)
    params = {
        "hh_threshold": hh_threshold,
        "hh_relative": hh_relative,
        "norm": norm,
        "pattern": pattern,
        "include_edge": include_edge,
        "include_self": include_self,
        "max_path": max_path,
        "half_max_disparity": d_half,
        "n_bits": bits,
        "ct_ops": ct_ops,
    }
    return CTHWResult(
        disparity=full,
        ops=coarse_ops,
        method="cthw",
        window=window,
        max_disparity=d_full,
        params=types.MappingProxyType(params),
        coarse=coarse_disp,
        hh_edges=edges,
    )
