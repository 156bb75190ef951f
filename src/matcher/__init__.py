"""Census stereo matchers: census / sparse census transforms, Hamming costs, WTA and ``match``,
the seed paper's CTHW, AWCT and AWSCT, Canny edges, the Haar transform and the metrics.

This is the whole public API; file formats are in :mod:`matcher.io`, hypothesis strategies in
:mod:`matcher.testing`. Only numpy, numba, OpenCV, scikit-image and scipy are imported here
(never ``synth``/``scenes``), and importing does nothing else.

Layout (each module imports only the ones above it in this list)::

    _validation  patterns  result  _kernels/     checks, census patterns, result types, numba
    census  cost  select  haar  edges  metrics   building blocks
    cthw  adaptive                               the seed paper's methods
    match                                        the dispatcher over every method
    regions  failures  processes  adapters       validation regions; any matcher behind one string
"""

from matcher.adapters import Matcher, MatcherError, MatcherFailure, MatcherOutcome, resolve_matcher
from matcher.adaptive import RIGHT_WINDOWS, AdaptiveResult, match_awct, match_awsct, select_windows
from matcher.census import census_transform, hamming
from matcher.benchmarks import (
    Eth3dMetrics,
    Kitti2015Metrics,
    KittiD1,
    MiddleburyV3Metrics,
    eth3d_two_view,
    kitti_2015,
    kitti_interpolate_background,
    middlebury_v3,
)
from matcher.cost import AGG_SENTINEL, COST_SENTINEL, aggregate_cost, cost_volume
from matcher.cthw import HH_THRESHOLD, CTHWResult, hh_edges, match_cthw, modify_disparity
from matcher.edges import CANNY_HIGH, CANNY_IMPLS, CANNY_LOW, CANNY_SIGMA, canny_edges
from matcher.haar import HAAR_NORMS, HaarBands, haar2d, ihaar2d
from matcher.match import METHODS, match
from matcher.metrics import Metrics, evaluate, pobmp, rms
from matcher.regions import REGIONS, region_masks, region_scores
from matcher.patterns import MAX_WINDOW, n_bits, n_words, sparse_pattern, spiral_offsets
from matcher.result import MatchResult, OpCounts
from matcher.select import winner_takes_all

__all__ = [
    "Matcher",
    "MatcherError",
    "MatcherFailure",
    "MatcherOutcome",
    "resolve_matcher",
    "REGIONS",
    "region_masks",
    "region_scores",
    "Eth3dMetrics",
    "Kitti2015Metrics",
    "KittiD1",
    "MiddleburyV3Metrics",
    "eth3d_two_view",
    "kitti_2015",
    "kitti_interpolate_background",
    "middlebury_v3",
    "AGG_SENTINEL",
    "AdaptiveResult",
    "CANNY_HIGH",
    "CANNY_IMPLS",
    "CANNY_LOW",
    "CANNY_SIGMA",
    "COST_SENTINEL",
    "CTHWResult",
    "HAAR_NORMS",
    "HH_THRESHOLD",
    "HaarBands",
    "MAX_WINDOW",
    "METHODS",
    "MatchResult",
    "Metrics",
    "OpCounts",
    "RIGHT_WINDOWS",
    "aggregate_cost",
    "canny_edges",
    "census_transform",
    "cost_volume",
    "evaluate",
    "haar2d",
    "hamming",
    "hh_edges",
    "ihaar2d",
    "match",
    "match_awct",
    "match_awsct",
    "match_cthw",
    "modify_disparity",
    "n_bits",
    "n_words",
    "pobmp",
    "rms",
    "select_windows",
    "sparse_pattern",
    "spiral_offsets",
    "winner_takes_all",
]
