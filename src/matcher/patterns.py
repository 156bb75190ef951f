"""Census patterns: the seed paper's spiral bit order and the sparse census patterns.

**Spiral bit order** (paper §3.2, Fig. 5: "counter-clockwise from the centre outward"). Offsets
are ``(dy, dx)`` with ``y`` down (image rows) and ``x`` right. Ring ``r`` (the pixels with
``max(|dy|, |dx|) == r``) starts right of the centre at ``(0, +r)`` and runs counter-clockwise
*as seen on screen*: up the right edge to ``(-r, +r)``, left along the top edge to ``(-r, -r)``,
down the left edge to ``(+r, -r)``, right along the bottom edge to ``(+r, +r)`` and up the right
edge to ``(+1, +r)``. Ring 1 is therefore::

    bit:  3 2 1        offsets: (-1,-1) (-1,0) (-1,+1)
          4 . 0                 ( 0,-1)   .    ( 0,+1)
          5 6 7                 (+1,-1) (+1,0) (+1,+1)

Rings follow each other from the centre outward, so the code of a ``w x w`` window is a prefix
(its first ``w*w - 1`` bits) of the code of every larger window at the same pixel.

**Sparse census (SCT) patterns**: point-symmetric subsets of the dense spiral. The seed paper
(§3.3, Fig. 6) uses the 16-point, 7 x 7, symmetric pattern of Fife & Archibald (2013) and
"expands" it to windows 3 x 3 ... 21 x 21. The figure is not available to us, so the pattern is a
reconstruction (see ``docs/matcher.md``):

* 7 x 7: the 16 pixels with both ``dy`` and ``dx`` odd, ``{-3, -1, 1, 3}^2`` -- every second
  pixel of every second row around the centre, the classic 16-comparison sparse census;
* extension: the same lattice, ``S(w) = {(dy, dx): dy, dx odd, |dy|, |dx| <= w // 2}``.

Every pattern is point-symmetric (``p in S => -p in S``), a subset of the dense window, listed in
the dense spiral order, and -- because it is the same lattice cut by growing squares -- ``S(w)``
is a prefix of ``S(w + 2)``, as the adaptive sparse method (AWSCT) needs. Rings of even radius
hold no lattice point, so a window of side ``4k + 1`` has the same pattern as the one of side
``4k - 1`` (5 x 5 = 3 x 3, 9 x 9 = 7 x 7, ...). :func:`matcher.pattern_figure.draw_patterns`
draws them.

A leaf module: the census, cost and method modules build on it; it imports none of them.
"""

from __future__ import annotations

import numpy as np

from matcher._validation import check_window

__all__ = [
    "MAX_WINDOW",
    "check_side",
    "n_bits",
    "n_words",
    "resolve_offsets",
    "sparse_pattern",
    "spiral_offsets",
]

#: Largest window side accepted (its 65,024 bits keep uint16 costs below the sentinel 65,535).
MAX_WINDOW = 255


def check_side(window: object) -> int:
    """Validate a window side without an image: an odd integer in ``[3, MAX_WINDOW]``.

    Examples
    --------
    >>> check_side(7)
    7
    """
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
    w = check_side(window)
    out = []
    for r in range(1, w // 2 + 1):
        out += [(-k, r) for k in range(0, r + 1)]  # up the right edge: (0,r) .. (-r,r)
        out += [(-r, r - k) for k in range(1, 2 * r + 1)]  # left along the top
        out += [(-r + k, -r) for k in range(1, 2 * r + 1)]  # down the left edge
        out += [(r, -r + k) for k in range(1, 2 * r + 1)]  # right along the bottom
        out += [(r - k, r) for k in range(1, r)]  # up the right edge to (1, r)
    return np.asarray(out, dtype=np.int64).reshape(-1, 2)


def sparse_pattern(window: int) -> np.ndarray:
    """Offsets of the sparse census pattern of a window, in spiral bit order.

    Parameters
    ----------
    window : int
        Odd window side, ``3 <= window <= 255``.

    Returns
    -------
    (n, 2) int64 array
        ``(dy, dx)`` offsets with ``dy`` and ``dx`` odd; ``n = ((window + 1) // 4 * 2) ** 2``
        (4 for 3 x 3 and 5 x 5, 16 for 7 x 7 and 9 x 9, ..., 100 for 21 x 21).

    References
    ----------
    W. S. Fife and J. K. Archibald, "Improved Census Transforms for Resource-Optimized Stereo
    Vision", IEEE TCSVT 23(1):60-73, 2013. Liaw et al., Sensors 20(9):2537, 2020, Fig. 6.

    Examples
    --------
    >>> sparse_pattern(3).tolist()
    [[-1, 1], [-1, -1], [1, -1], [1, 1]]
    >>> len(sparse_pattern(7))
    16
    """
    dense = spiral_offsets(check_side(window))
    odd = (dense[:, 0] % 2 == 1) & (dense[:, 1] % 2 == 1)
    return dense[odd]


def resolve_offsets(window: int, pattern: object) -> np.ndarray:
    """The ``(dy, dx)`` offsets of a census pattern in a window.

    Parameters
    ----------
    window : int
        A validated odd window side (:func:`check_side`).
    pattern : {"dense", "sparse"} or (n, 2) int array
        :func:`spiral_offsets`, :func:`sparse_pattern` or custom offsets (checked: non-zero,
        inside the window, at most ``window**2 - 1`` of them; used in the given order).

    Returns
    -------
    (n, 2) int64 array

    Examples
    --------
    >>> resolve_offsets(3, [[0, 1], [1, 1]]).tolist()
    [[0, 1], [1, 1]]
    """
    if isinstance(pattern, str):
        if pattern == "dense":
            return spiral_offsets(window)
        if pattern == "sparse":
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
    return int(resolve_offsets(check_side(window), pattern).shape[0])


def n_words(bits: int) -> int:
    """Number of uint64 words holding ``bits`` bits.

    Examples
    --------
    >>> n_words(440)
    7
    """
    return (int(bits) + 63) // 64
