"""What a matcher returns: :class:`MatchResult` and its operation counts, :class:`OpCounts`.

A leaf module: every method module (:mod:`matcher.match`, :mod:`matcher.cthw`,
:mod:`matcher.adaptive`) builds its result on these types; this module imports none of them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from matcher.patterns import n_words

__all__ = ["MatchResult", "OpCounts", "census_ops"]


@dataclass(frozen=True)
class OpCounts:
    """Operation counts of a census match (both views).

    Attributes
    ----------
    census_comparisons : int
        Census bits computed, summed over the pixels of both images: ``2 * H * W * n_bits``.
    hamming_words : int
        64-bit XOR + popcount operations of the per-pixel Hamming costs: ``n_words`` per left
        pixel and candidate, ``H * n_words * sum_{d < D} (W - d)``. Counted algorithmically: the
        LR check reuses these costs, and the aggregation's recomputed halo rows are not counted.
    """

    census_comparisons: int
    hamming_words: int


@dataclass(frozen=True, eq=False)
class MatchResult:
    """Output of :func:`matcher.match`.

    Attributes
    ----------
    disparity : (H, W) float32 array
        Left-view disparity in pixels; ``inf`` where invalid.
    ops : OpCounts or None
        Operation counts for "ct" and "sct"; ``None`` for "bm" and "sgbm" (not defined).
    method, window, max_disparity
        The arguments used.
    params : Mapping[str, object]
        Every other setting (read-only), including OpenCV's for the baselines.
    """

    disparity: np.ndarray
    ops: OpCounts | None
    method: str
    window: int
    max_disparity: int
    params: Mapping[str, object]


def census_ops(shape: tuple[int, int], bits: int, max_disparity: int) -> OpCounts:
    """Operation counts of a census match with ``bits``-bit codes (see :class:`OpCounts`).

    Parameters
    ----------
    shape : (int, int)
        ``(H, W)`` of each view.
    bits : int
        Code length (:func:`matcher.n_bits`).
    max_disparity : int
        Number of candidates ``D`` (``< W``).

    Examples
    --------
    >>> census_ops((2, 10), 8, 3)
    OpCounts(census_comparisons=320, hamming_words=54)
    """
    h, w = shape
    d = max_disparity
    return OpCounts(
        census_comparisons=2 * h * w * bits,
        hamming_words=h * n_words(bits) * (d * w - d * (d - 1) // 2),
    )
