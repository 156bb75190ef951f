"""Adaptive window census transform (AWCT) and its sparse variant (AWSCT), the seed paper's
§3.2-3.3 and Fig. 4-6.

Window choice (:func:`select_windows`), per pixel ``p``, from the sides ``min_window, min_window
+ 2, .., max_window`` [3 .. 21] and a Canny edge map of the left image
(:func:`matcher.edges.canny_edges`):

* the *proportion* of window ``s`` is (edge pixels in the ``s x s`` window centred on ``p``) /
  ``s**2``; pixels outside the image count as non-edge;
* going from each side to the next larger one, a strict decrease of the proportion is one
  "negative growth"; the side chosen is the first at which ``n_decreases`` [N = 5] negative
  growths have happened *in a row*;
* if that never happens, the largest side is chosen. This covers the paper's "no edge point in
  the window" case (the proportion stays 0, never decreases) and the case the paper leaves open,
  reaching the largest side first. With N = 5 and sides from 3, no side below 13 can be chosen.

Matching: census codes are computed once per view at ``max_window``; the spiral bit order
(:mod:`matcher.patterns`) makes the code of every smaller window a prefix of it, and the sparse
patterns (:mod:`matcher.patterns`) are prefixes of each other too. The cost of a left pixel ``p``
with window ``w_L(p)`` and a right pixel ``q = p - d`` with window ``w_R(q)`` is the Hamming
distance of the two codes' first ``n_bits(min(w_L(p), w_R(q)))`` bits (the paper's "the smaller
window size is selected"); winner-takes-all, ties to the smallest ``d``, as :func:`matcher.match`.

The paper takes edges from the left image only and does not say which window a right pixel
has. ``right_windows`` makes it explicit:

* ``"left_pixel"`` [default]: every candidate of a left pixel ``p`` is compared over ``p``'s own
  window. Implemented as the min rule with ``w_R(q)`` = the largest left window that is ever
  compared with ``q`` (``max w_L(y, x)`` over ``q <= x < q + D``), which is also the code length
  the right view must compute at ``q``; so ``min(w_L(p), w_R(p - d)) = w_L(p)`` always.
* ``"left_map"``: the left map applied to the right image at the same coordinates
  (``w_R(y, x) = w_L(y, x)``) with the min rule.
* ``"right_edges"``: the same selection on Canny edges of the right image, with the min rule.

With the min rule, the candidates of one left pixel are scored over different numbers of bits,
so a candidate whose right pixel has a small window gets a smaller Hamming distance for that
reason alone and wins winner-takes-all too often. On Middlebury this costs 6-13 points of PoBMP
against CT (see ``docs/paper.md``); ``"left_pixel"`` keeps the costs of one pixel comparable and
matches CT's accuracy, which is what the paper reports for AWCT. That is why it is the default.

Operation counts: ``census_comparisons`` = the bits each pixel's window needs, summed over both
views; ``hamming_words`` = 64-bit word operations, ``ceil(n_bits(min window) / 64)`` per left
pixel and candidate. ``reduction_ratio = 1 - census_comparisons / census_comparisons(CT at
max_window)``, the paper's "reduction ratio of operation" (Tables 2-3).
"""

from __future__ import annotations

import functools
import types
from dataclasses import dataclass
from typing import Literal

import numba
import numpy as np

from matcher._kernels import adaptive_wta_kernel, edge_integral, select_windows_kernel
from matcher._validation import check_image, check_int, check_max_disparity, check_same_shape, check_window
from matcher.census import padded_grey
from matcher.edges import CANNY_HIGH, CANNY_IMPLS, CANNY_LOW, CANNY_SIGMA, canny_edges
from matcher.patterns import MAX_WINDOW, n_bits, resolve_offsets
from matcher.result import MatchResult, OpCounts, census_ops

__all__ = ["AdaptiveResult", "RIGHT_WINDOWS", "match_awct", "match_awsct", "select_windows"]

#: Accepted values of ``right_windows``.
RIGHT_WINDOWS = ("left_pixel", "left_map", "right_edges")


@dataclass(frozen=True)
class AdaptiveResult(MatchResult):
    """:class:`matcher.result.MatchResult` of AWCT/AWSCT, with the window maps.

    ``window`` is ``max_window``. Extra attributes:

    Attributes
    ----------
    window_map : (H, W) uint8 array
        Window side of each left pixel.
    window_map_right : (H, W) uint8 array
        Window side of each right pixel: the code length computed there (see
        ``right_windows``; equal to ``window_map`` for ``"left_map"``).
    edges : (H, W) bool array
        Canny edges of the left image.
    reduction_ratio : float
        ``1 - census comparisons / census comparisons of CT at max_window``.
    """

    window_map: np.ndarray
    window_map_right: np.ndarray
    edges: np.ndarray
    reduction_ratio: float


@functools.lru_cache(maxsize=32)
def _code_tables(min_window: int, max_window: int, pattern: str) -> tuple[np.ndarray, np.ndarray]:
    """``(bits_of, offsets)``: code length per side (0 elsewhere) and the largest window's
    offsets, cached (they only depend on the arguments); read-only arrays."""
    bits_of = np.zeros(max_window + 1, dtype=np.int64)
    for s in range(min_window, max_window + 1, 2):
        bits_of[s] = n_bits(s, pattern)
    offsets = resolve_offsets(max_window, pattern)
    bits_of.flags.writeable = False
    offsets.flags.writeable = False
    return bits_of, offsets


def _check_edges(edges: object) -> np.ndarray:
    """A validated, C-contiguous (H, W) bool edge map."""
    if not isinstance(edges, np.ndarray) or edges.dtype != np.bool_ or edges.ndim != 2:
        got = (
            f"array of shape {edges.shape} and dtype {edges.dtype}"
            if isinstance(edges, np.ndarray) else type(edges).__name__
        )
        raise TypeError(
            f"edges: expected an (H, W) bool array, got {got}; use canny_edges(image) or "
            "edges.astype(bool)"
        )
    return np.ascontiguousarray(edges)


def _window_sides(min_window: object, max_window: object) -> np.ndarray:
    """Validated candidate sides ``min_window, min_window + 2, .., max_window``."""
    sides = []
    for name, value in (("min_window", min_window), ("max_window", max_window)):
        v = check_int(value, name, lo=3, fix="window sides are odd integers >= 3, e.g. 21")
        if v % 2 == 0:
            raise ValueError(f"{name}: expected an odd integer >= 3, got {v}; try {v + 1}")
        if v > MAX_WINDOW:
            raise ValueError(f"{name}: expected at most {MAX_WINDOW}, got {v}")
        sides.append(v)
    lo, hi = sides
    if lo > hi:
        raise ValueError(
            f"min_window, max_window: expected min_window <= max_window, got {lo} and {hi}; "
            "swap them"
        )
    return np.arange(lo, hi + 1, 2, dtype=np.int64)


def select_windows(
    edges: np.ndarray,
    *,
    max_window: int = 21,
    n_decreases: int = 5,
    min_window: int = 3,
) -> np.ndarray:
    """Choose a census window side per pixel from an edge map (AWCT, paper §3.2).

    Parameters
    ----------
    edges : (H, W) bool array
        Edge map (e.g. :func:`matcher.edges.canny_edges` of the left image).
    max_window : int, default 21
        Largest side (odd, ``>= min_window``, ``<= 255``).
    n_decreases : int, default 5
        ``N``: the number of consecutive decreases of the edge proportion that selects a side;
        ``>= 1``.
    min_window : int, default 3
        Smallest side (odd, ``>= 3``).

    Returns
    -------
    (H, W) uint8 array
        The chosen side of every pixel, one of ``min_window, min_window + 2, .., max_window``.
        The choice at ``p`` depends only on the edges inside the ``max_window`` square around
        ``p``. See the module docstring for the rule.

    References
    ----------
    Liaw et al., Sensors 20(9):2537, 2020, §3.2 and Fig. 4.

    Examples
    --------
    One edge pixel: from the centre, the proportions are 1/9, 1/25, 1/49, ... (always
    decreasing), so with N = 2 the centre gets side 7 (two decreases: 3 -> 5 -> 7). A pixel
    whose windows never contain the edge gets the largest side.

    >>> import numpy as np
    >>> e = np.zeros((40, 40), bool)
    >>> e[20, 20] = True
    >>> m = select_windows(e, max_window=11, n_decreases=2)
    >>> int(m[20, 20]), int(m[0, 0])
    (7, 11)
    """
    edges = _check_edges(edges)
    sides = _window_sides(min_window, max_window)
    n = check_int(n_decreases, "n_decreases", lo=1, fix="the paper uses N = 5")
    out = np.empty(edges.shape, dtype=np.uint8)
    select_windows_kernel(
        edges, sides, n, numba.get_num_threads(), np.zeros(1, np.int64), out
    )
    return out


def match_awct(
    left: np.ndarray,
    right: np.ndarray,
    *,
    max_window: int = 21,
    max_disparity: int = 64,
    n_decreases: int = 5,
    min_window: int = 3,
    sigma: float = CANNY_SIGMA,
    low: float = CANNY_LOW,
    high: float = CANNY_HIGH,
    right_windows: Literal["left_pixel", "left_map", "right_edges"] = "left_pixel",
    pattern: Literal["dense", "sparse"] = "dense",
    edges: np.ndarray | None = None,
    canny_impl: Literal["skimage", "opencv"] = "opencv",
) -> AdaptiveResult:
    """Adaptive window census transform (AWCT; AWSCT with ``pattern="sparse"``).

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) uint8, integer or float arrays
        Rectified views, same shape; RGB is converted to grey (BT.601).
    max_window : int, default 21
        Largest census window side (odd, ``<= min(H, W)``).
    max_disparity : int, default 64
        Number of candidates ``D`` (disparities ``0 .. D - 1``), ``1 <= D < W``.
    n_decreases : int, default 5
        ``N`` of :func:`select_windows`.
    min_window : int, default 3
        Smallest window side.
    sigma, low, high : float
        Canny parameters (:func:`matcher.edges.canny_edges`).
    right_windows : {"left_pixel", "left_map", "right_edges"}, default "left_pixel"
        Where the right view's windows come from (see the module docstring).
    pattern : {"dense", "sparse"}, default "dense"
        ``"sparse"`` uses :func:`matcher.patterns.sparse_pattern` (AWSCT).
    edges : (H, W) bool array or None, default None
        A precomputed edge map of the left image to use instead of Canny's (``sigma``, ``low``
        and ``high`` are then ignored for the left view).
    canny_impl : {"opencv", "skimage"}, default "opencv"
        ``impl`` of :func:`matcher.edges.canny_edges`; ``"opencv"`` is ~10x faster than the
        ``"skimage"`` reference, with slightly different edge maps (see :mod:`matcher.edges`).

    Returns
    -------
    AdaptiveResult
        ``disparity`` (H, W) float32 integer disparities, ``ops``, ``method`` ("awct" or
        "awsct"), ``window = max_window``, ``params`` (every setting, ``ct_ops`` of CT/SCT at
        ``max_window``, ``hamming_bits``), ``window_map``, ``window_map_right``, ``edges``,
        ``reduction_ratio``.

    References
    ----------
    Liaw et al., "Improving Census Transform by High-Pass with Haar Wavelet Transform and Edge
    Detection", Sensors 20(9):2537, 2020, §3.2-3.3.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (32, 48), dtype=np.uint8)
    >>> left = np.roll(right, 3, axis=1)
    >>> res = match_awct(left, right, max_window=7, max_disparity=8)
    >>> float(np.median(res.disparity[:, 8:])), 0.0 <= res.reduction_ratio < 1.0
    (3.0, True)
    """
    grey_l = check_image(left, "left")
    grey_r = check_image(right, "right")
    check_same_shape(grey_l, grey_r)
    sides = _window_sides(min_window, max_window)
    max_window = check_window(int(sides[-1]), "max_window", image_shape=grey_l.shape)
    d = check_max_disparity(max_disparity, grey_l.shape[1])
    n = check_int(n_decreases, "n_decreases", lo=1, fix="the paper uses N = 5")
    if right_windows not in RIGHT_WINDOWS:
        raise ValueError(f"right_windows: expected one of {RIGHT_WINDOWS}, got {right_windows!r}")
    if pattern not in ("dense", "sparse"):
        raise ValueError(f"pattern: expected 'dense' or 'sparse', got {pattern!r}")
    if canny_impl not in CANNY_IMPLS:
        raise ValueError(
            f"canny_impl: expected one of {CANNY_IMPLS}, got {canny_impl!r}; 'opencv' is the "
            "fast default, 'skimage' the reference"
        )

    if edges is None:
        # the original image, not grey_l: Canny's thresholds are fractions of the input dtype's
        # range, which check_image's float conversion of a uint16 image would lose
        edges = canny_edges(left, sigma=sigma, low=low, high=high, impl=canny_impl)
    elif not (isinstance(edges, np.ndarray) and edges.shape == grey_l.shape):
        raise ValueError(
            f"edges: expected None or a bool array of shape {grey_l.shape} (the image's), got "
            f"{getattr(edges, 'shape', type(edges).__name__)}"
        )
    edges = _check_edges(edges)
    wmap = np.empty(grey_l.shape, dtype=np.uint8)  # chosen inside the kernel, row by row
    integral, pad = edge_integral(edges, max_window)
    if right_windows == "right_edges":
        edges_r = canny_edges(right, sigma=sigma, low=low, high=high, impl=canny_impl)
        wmap_r = select_windows(
            edges_r, max_window=max_window, n_decreases=n, min_window=int(sides[0])
        )
    else:
        wmap_r = np.empty_like(wmap)  # written by the kernel
    right_mode = {"right_edges": 0, "left_pixel": 1, "left_map": 2}[right_windows]

    bits_of, offsets = _code_tables(int(sides[0]), max_window, pattern)
    total_bits = int(bits_of[max_window])
    disp = np.empty(grey_l.shape, dtype=np.float32)
    rows = np.empty((grey_l.shape[0], 4), dtype=np.int64)
    adaptive_wta_kernel(
        padded_grey(grey_l, max_window), padded_grey(grey_r, max_window), offsets, max_window // 2,
        wmap, wmap_r, bits_of, d, right_windows == "left_pixel", integral, pad, sides, n,
        right_mode, numba.get_num_threads(), np.zeros(1, np.int64), disp, rows,
    )
    h, w = grey_l.shape
    ops = OpCounts(
        census_comparisons=int(rows[:, 2].sum() + rows[:, 3].sum()),
        hamming_words=int(rows[:, 1].sum()),
    )
    ct_ops = census_ops((h, w), total_bits, d)
    ratio = 1.0 - ops.census_comparisons / ct_ops.census_comparisons
    params = {
        "min_window": int(sides[0]),
        "n_decreases": n,
        "sigma": float(sigma),
        "low": float(low),
        "high": float(high),
        "right_windows": right_windows,
        "pattern": pattern,
        "canny_impl": canny_impl,
        "hamming_bits": int(rows[:, 0].sum()),
        "ct_ops": ct_ops,
    }
    return AdaptiveResult(
        disparity=disp,
        ops=ops,
        method="awct" if pattern == "dense" else "awsct",
        window=max_window,
        max_disparity=d,
        params=types.MappingProxyType(params),
        window_map=wmap,
        window_map_right=wmap_r,
        edges=edges,
        reduction_ratio=float(ratio),
    )


def match_awsct(
    left: np.ndarray,
    right: np.ndarray,
    *,
    max_window: int = 21,
    max_disparity: int = 64,
    n_decreases: int = 5,
    min_window: int = 3,
    sigma: float = CANNY_SIGMA,
    low: float = CANNY_LOW,
    high: float = CANNY_HIGH,
    right_windows: Literal["left_pixel", "left_map", "right_edges"] = "left_pixel",
    edges: np.ndarray | None = None,
    canny_impl: Literal["skimage", "opencv"] = "opencv",
) -> AdaptiveResult:
    """Adaptive window sparse census transform (AWSCT, paper §3.3).

    :func:`match_awct` with ``pattern="sparse"`` (:func:`matcher.patterns.sparse_pattern`); see
    there for the parameters.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> right = rng.integers(0, 256, (32, 48), dtype=np.uint8)
    >>> res = match_awsct(np.roll(right, 3, axis=1), right, max_window=7, max_disparity=8)
    >>> res.method, float(np.median(res.disparity[:, 8:]))
    ('awsct', 3.0)
    """
    return match_awct(
        left, right, max_window=max_window, max_disparity=max_disparity,
        n_decreases=n_decreases, min_window=min_window, sigma=sigma, low=low, high=high,
        right_windows=right_windows, pattern="sparse", edges=edges, canny_impl=canny_impl,
    )
