"""Census stereo matchers: census / sparse census transforms, Hamming costs, WTA and ``match``.

Only numpy, numba, OpenCV, scikit-image and scipy are imported here (never ``synth``/``scenes``).
"""

from matcher.census import census_transform, hamming, n_bits, spiral_offsets
from matcher.cost import aggregate_cost, cost_volume
from matcher.match import METHODS, MatchResult, OpCounts, match
from matcher.select import winner_takes_all
from matcher.sparse import sparse_pattern

__all__ = [
    "METHODS",
    "MatchResult",
    "OpCounts",
    "aggregate_cost",
    "census_transform",
    "cost_volume",
    "hamming",
    "match",
    "n_bits",
    "sparse_pattern",
    "spiral_offsets",
    "winner_takes_all",
]
