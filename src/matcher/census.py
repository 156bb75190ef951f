"""Census transform (CT) with the seed paper's spiral bit order, packed into uint64 words.

Bit order (paper §3.2, Fig. 5: "counter-clockwise from the centre outward"). Offsets are
``(dy, dx)`` with ``y`` down (image rows) and ``x`` right. Ring ``r`` (the pixels with
``max(|dy|, |dx|) == r``) starts right of the centre at ``(0, +r)`` and runs counter-clockwise
*as seen on screen*: up the right edge to ``(-r, +r)``, left along the top edge to ``(-r, -r)``,
down the left edge to ``(+r, -r)``, right along the bottom edge to ``(+r, +r)`` and up the right
edge to ``(+1, +r)``. Ring 1 is therefore::

    bit:  3 2 1        offsets: (-1,-1) (-1,0) (-1,+1)
          4 . 0                 ( 0,-1)   .    ( 0,+1)
          5 6 7                 (+1,-1) (+1,0) (+1,+1)

Rings follow each other from the centre outward, so the code of a ``w x w`` window is a prefix
(its first ``w*w - 1`` bits) of the code of every larger window at the same pixel. Bit ``i`` of a
code is bit ``i % 64`` of word ``i // 64`` (little-endian words).

A bit is 1 iff the centre is brighter than the neighbour, ``I(p) > I(p')`` (paper Eq. 2).
Outside the image the edge is replicated (``np.pad(mode="edge")``).
"""

from __future__ import annotations

import numba
import numpy as np

from matcher import _kernels
from matcher._validation import check_image, check_window

__all__ = ["MAX_WINDOW", "census_transform", "hamming", "n_bits", "n_words", "spiral_offsets"]

#: Largest window side accepted (its 65,024 bits keep uint16 costs below the sentinel 65,535).
MAX_WINDOW = 255


def _check_side(window: object) -> int:
    """Validate a window side without an image: odd int in [3, MAX_WINDOW]."""
    w = check_window(window, "window", image_shape=(1 << 30, 1 << 30))
    if w > MAX_WINDOW:
        raise ValueError(f"window: expected at most {MAX_WINDOW}, got {w}; use a smaller window")
    return w


def spiral_offsets(window: int) -> np.ndarray:
    """Neighbour offsets of a square window in the spiral bit order.

    Parameters
    ----------
    window : int
        Odd window side, ``3 <= window <= MAX_WINDOW``.

    Returns
    -------
    (window**2 - 1, 2) int64 array
        ``(dy, dx)`` per bit; row ``k`` is the neighbour of bit ``k``.

    References
    ----------
    Liaw et al., "Improving Census Transform by High-Pass with Haar Wavelet Transform and Edge
    Detection", Sensors 20(9):2537, 2020, §3.2 and Fig. 5.

    Examples
    --------
    >>> spiral_offsets(3).tolist()
    [[0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0], [1, 1]]
    >>> bool((spiral_offsets(7)[:24] == spiral_offsets(5)).all())
    True
    """
    w = _check_side(window)
    out = []
    for r in range(1, w // 2 + 1):
        out += [(-k, r) for k in range(0, r + 1)]  # up the right edge: (0,r) .. (-r,r)
        out += [(-r, r - k) for k in range(1, 2 * r + 1)]  # left along the top
        out += [(-r + k, -r) for k in range(1, 2 * r + 1)]  # down the left edge
        out += [(r, -r + k) for k in range(1, 2 * r + 1)]  # right along the bottom
        out += [(r - k, r) for k in range(1, r)]  # up the right edge to (1, r)
    return np.asarray(out, dtype=np.int64).reshape(-1, 2)


def _resolve_offsets(window: int, pattern: object) -> np.ndarray:
    """Offsets (n, 2) int64 for ``pattern`` ("dense", "sparse" or an array) in a validated window."""
    if isinstance(pattern, str):
        if pattern == "dense":
            return spiral_offsets(window)
        if pattern == "sparse":
            from matcher.sparse import sparse_pattern  # sparse.py imports this module

            return sparse_pattern(window)
        raise ValueError(
            f"pattern: expected 'dense', 'sparse' or an (n, 2) offsets array, got {pattern!r}"
        )
    offsets = np.asarray(pattern)
    if offsets.dtype.kind not in "iu" or offsets.ndim != 2 or offsets.shape[1] != 2:
        raise ValueError(
            "pattern: expected 'dense', 'sparse' or an (n, 2) integer array of (dy, dx) "
            f"offsets, got array of shape {offsets.shape} and dtype {offsets.dtype}"
        )
    r = window // 2
    if offsets.shape[0] == 0 or offsets.shape[0] > window * window - 1:
        raise ValueError(
            f"pattern: expected 1..{window * window - 1} offsets, got {offsets.shape[0]}"
        )
    if np.abs(offsets).max() > r or not np.any(offsets, axis=1).all():
        raise ValueError(
            f"pattern: expected non-zero offsets with |dy|, |dx| <= {r} for window {window}, "
            f"got {offsets.tolist()}; enlarge the window or drop those offsets"
        )
    return offsets.astype(np.int64)


def n_bits(window: int, pattern: object = "dense") -> int:
    """Number of bits of a census code (``window**2 - 1`` for the dense pattern).

    Examples
    --------
    >>> n_bits(21), n_bits(7, "sparse")
    (440, 16)
    """
    return int(_resolve_offsets(_check_side(window), pattern).shape[0])


def n_words(bits: int) -> int:
    """Number of uint64 words holding ``bits`` bits.

    Examples
    --------
    >>> n_words(440)
    7
    """
    return (int(bits) + 63) // 64


def _kernel_image(grey: np.ndarray) -> np.ndarray:
    """The grey image as the kernels take it: uint8, float32 or float64 (all exact)."""
    if grey.dtype in (np.uint8, np.float64):
        return np.ascontiguousarray(grey)
    return np.ascontiguousarray(grey, dtype=np.float32)


def _codes_planar(grey: np.ndarray, offsets: np.ndarray, window: int) -> np.ndarray:
    """Census codes in the kernels' (H, n_words, W) layout; input trusted."""
    r = window // 2
    padded = _padded(grey, window)
    h, w = grey.shape
    out = np.empty((h, n_words(offsets.shape[0]), w), dtype=np.uint64)
    _kernels.census_rows_kernel(
        padded, np.ascontiguousarray(offsets, dtype=np.int64), r, numba.get_num_threads(),
        np.zeros(1, np.int64), out,
    )
    return out


def _padded(grey: np.ndarray, window: int) -> np.ndarray:
    """The grey image as the kernels take it, edge-padded by ``window // 2``; input trusted."""
    return np.pad(_kernel_image(grey), window // 2, mode="edge")


def census_transform(image: np.ndarray, *, window: int, pattern: object = "dense") -> np.ndarray:
    """Census transform of an image, packed into uint64 words.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8, integer or float array
        Grey or RGB image (RGB is converted to grey with BT.601 weights).
    window : int
        Odd window side, ``3 <= window <= min(H, W)`` and ``<= MAX_WINDOW``.
    pattern : {"dense", "sparse"} or (n, 2) int array, default "dense"
        ``"dense"``: every pixel of the window in spiral order; ``"sparse"``: the sparse census
        pattern of :func:`matcher.sparse.sparse_pattern`; an array: custom ``(dy, dx)`` offsets,
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
    w = _check_side(w)
    offsets = _resolve_offsets(w, pattern)
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
