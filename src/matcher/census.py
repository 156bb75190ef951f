"""Census transform (CT) packed into uint64 words, Hamming distances, and the fused census
matcher behind :func:`matcher.match`.

Bit order: the spiral order of :mod:`matcher.patterns` (or a sparse or custom pattern). Bit ``i``
of a code is bit ``i % 64`` of word ``i // 64`` (little-endian words).

A bit is 1 iff the centre is brighter than the neighbour, ``I(p) > I(p')`` (paper Eq. 2).
Outside the image the edge is replicated (``np.pad(mode="edge")``).

:func:`census_disparity` runs one fused numba kernel (census codes -> Hamming -> optional box
aggregation -> winner-takes-all -> optional LR check and subpixel), parallel over rows, without
an ``(H, D, W)`` cost volume. Its result equals ``winner_takes_all(cost_volume(...))`` of
:mod:`matcher.cost` / :mod:`matcher.select` exactly; the rules are documented there.
"""

from __future__ import annotations

import numba
import numpy as np

from matcher._kernels import census_match_kernel, census_rows_kernel
from matcher._validation import check_image, check_window
from matcher.patterns import check_side, n_words, resolve_offsets

__all__ = ["census_disparity", "census_transform", "hamming", "padded_grey"]

# Per-thread budget for the (strip, D, W) cost buffers of the aggregated path.
_STRIP_BUDGET_BYTES = 48 * 2**20
# Rows per work item of the per-pixel (non-aggregated) path.
_ROWS_PER_ITEM = 2


def _kernel_image(grey: np.ndarray) -> np.ndarray:
    """The grey image as the kernels take it: uint8, float32 or float64 (all exact)."""
    if grey.dtype in (np.uint8, np.float64):
        return np.ascontiguousarray(grey)
    return np.ascontiguousarray(grey, dtype=np.float32)


def _codes_planar(grey: np.ndarray, offsets: np.ndarray, window: int) -> np.ndarray:
    """Census codes in the kernels' (H, n_words, W) layout; input trusted."""
    r = window // 2
    padded = padded_grey(grey, window)
    h, w = grey.shape
    out = np.empty((h, n_words(offsets.shape[0]), w), dtype=np.uint64)
    census_rows_kernel(
        padded, np.ascontiguousarray(offsets, dtype=np.int64), r, numba.get_num_threads(),
        np.zeros(1, np.int64), out,
    )
    return out


def padded_grey(grey: np.ndarray, window: int) -> np.ndarray:
    """The grey image as the census kernels take it, edge-padded by ``window // 2``.

    Input trusted: an (H, W) grey array as :func:`matcher._validation.check_image` returns it.
    uint8, float32 and float64 stay as they are, other dtypes become float32 (all exact).

    Examples
    --------
    >>> import numpy as np
    >>> padded_grey(np.array([[1, 2]], np.uint8), 3).tolist()
    [[1, 1, 2, 2], [1, 1, 2, 2], [1, 1, 2, 2]]
    """
    return np.pad(_kernel_image(grey), window // 2, mode="edge")


def _strip_rows(max_disparity: int, width: int, half: int) -> int:
    per_row = 2 * max_disparity * width * 4
    return int(np.clip(_STRIP_BUDGET_BYTES // per_row - 2 * half, 8, 64))


def census_disparity(
    grey_l: np.ndarray,
    grey_r: np.ndarray,
    offsets: np.ndarray,
    *,
    window: int,
    max_disparity: int,
    aggregate: int | None = None,
    lr_tolerance: int | None = None,
    subpixel: bool = False,
) -> np.ndarray:
    """Census winner-takes-all disparity of two grey views with the fused kernel; input trusted.

    The engine of :func:`matcher.match` for ``"ct"``/``"sct"`` and of CTHW's half-resolution
    match. No validation: the caller has checked everything :func:`matcher.match` checks.

    Parameters
    ----------
    grey_l, grey_r : (H, W) uint8 or float arrays
        Same shape, as :func:`matcher._validation.check_image` returns them.
    offsets : (n, 2) int64 array
        Census offsets inside the window (:func:`matcher.patterns.resolve_offsets`).
    window : int
        Odd window side; the images are edge-padded by ``window // 2``.
    max_disparity : int
        Number of candidates ``D``, ``1 <= D < W``.
    aggregate : int or None, default None
        Odd box side of the cost aggregation (``None``: per-pixel Hamming costs); the caller
        makes sure ``aggregate**2 * n`` fits in uint32.
    lr_tolerance : int or None, default None
        Left-right check tolerance (``None``: no check).
    subpixel : bool, default False
        Parabola refinement.

    Returns
    -------
    (H, W) float32 array
        Disparity; ``inf`` where the LR check fails.

    Examples
    --------
    >>> import numpy as np
    >>> from matcher.patterns import spiral_offsets
    >>> right = np.random.default_rng(0).integers(0, 256, (16, 24), dtype=np.uint8)
    >>> d = census_disparity(np.roll(right, 2, axis=1), right, spiral_offsets(5), window=5,
    ...                      max_disparity=4)
    >>> float(np.median(d[:, 4:-2]))
    2.0
    """
    half = 0 if aggregate is None else aggregate // 2
    disp = np.empty(grey_l.shape, dtype=np.float32)
    strip = _strip_rows(max_disparity, grey_l.shape[1], half) if half else _ROWS_PER_ITEM
    census_match_kernel(
        padded_grey(grey_l, window), padded_grey(grey_r, window), offsets, window // 2,
        max_disparity, half, -1 if lr_tolerance is None else lr_tolerance, subpixel, strip,
        numba.get_num_threads(), np.zeros(1, np.int64), disp,
    )
    return disp


def census_transform(image: np.ndarray, *, window: int, pattern: object = "dense") -> np.ndarray:
    """Census transform of an image, packed into uint64 words.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8, integer or float array
        Grey or RGB image (RGB is converted to grey with BT.601 weights).
    window : int
        Odd window side, ``3 <= window <= min(H, W)`` and ``<= MAX_WINDOW`` (255).
    pattern : {"dense", "sparse"} or (n, 2) int array, default "dense"
        ``"dense"``: every pixel of the window in spiral order; ``"sparse"``: the sparse census
        pattern of :func:`matcher.patterns.sparse_pattern`; an array: custom ``(dy, dx)`` offsets,
        used in the given order.

    Returns
    -------
    (H, W, n_words) uint64 array
        Bit ``k`` (bit ``k % 64`` of word ``k // 64``) is 1 iff ``I(y, x) > I(y + dy_k, x + dx_k)``;
        unused high bits of the last word are 0.

    References
    ----------
    R. Zabih and J. Woodfill, "Non-parametric local transforms for computing visual
    correspondence", ECCV 1994. Bit order: Liaw et al., Sensors 20(9):2537, 2020, Fig. 5.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((3, 3), 10, np.uint8)
    >>> img[1, 2] = 0  # a dark pixel right of the centre: bit 0 of the centre's code
    >>> int(census_transform(img, window=3)[1, 1, 0])
    1
    """
    grey = check_image(image, "image")
    w = check_window(window, "window", image_shape=grey.shape)
    w = check_side(w)
    offsets = resolve_offsets(w, pattern)
    return np.ascontiguousarray(_codes_planar(grey, offsets, w).transpose(0, 2, 1))


def hamming(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamming distance between packed codes, summed over the last (word) axis.

    Parameters
    ----------
    a, b : (..., n_words) uint64 arrays
        Codes from :func:`census_transform`; broadcastable against each other.

    Returns
    -------
    (...) int64 array

    Examples
    --------
    >>> import numpy as np
    >>> int(hamming(np.array([0b1011], np.uint64), np.array([0b0001], np.uint64)))
    2
    """
    a = np.asarray(a)
    b = np.asarray(b)
    if a.dtype != np.uint64 or b.dtype != np.uint64:
        raise TypeError(
            f"a, b: expected uint64 codes, got dtypes {a.dtype} and {b.dtype}; "
            "use the output of census_transform"
        )
    return np.bitwise_count(a ^ b).sum(axis=-1, dtype=np.int64)
