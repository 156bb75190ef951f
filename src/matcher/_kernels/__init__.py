"""Numba kernels of the matchers, one module per method family. They trust their input: the
public functions of :mod:`matcher` validate it first.

Inside this package the modules share private row helpers (``_census_row`` ...); modules outside
it import only the names below.
"""

from matcher._kernels.adaptive import (
    adaptive_wta_kernel,
    edge_integral,
    right_window_map,
    select_windows_kernel,
)
from matcher._kernels.aggregate import AGG_SENTINEL, aggregate_kernel
from matcher._kernels.canny import canny_from_derivatives, canny_on_derivatives, canny_thresholds
from matcher._kernels.census import (
    COST_SENTINEL,
    census_match_kernel,
    census_rows_kernel,
    cost_volume_kernel,
)
from matcher._kernels.cthw import (
    disparity_range,
    haar_padded_kernel,
    key_shift,
    path_mode_up_kernel,
)
from matcher._kernels.grey import grey_uint8_kernel
from matcher._kernels.intrinsics import fetch_add, fma, popcount64
from matcher._kernels.learned import similarity_cost_kernel
from matcher._kernels.select import wta_kernel

__all__ = [
    "AGG_SENTINEL",
    "COST_SENTINEL",
    "adaptive_wta_kernel",
    "aggregate_kernel",
    "canny_from_derivatives",
    "canny_on_derivatives",
    "canny_thresholds",
    "census_match_kernel",
    "census_rows_kernel",
    "cost_volume_kernel",
    "disparity_range",
    "edge_integral",
    "fetch_add",
    "fma",
    "grey_uint8_kernel",
    "haar_padded_kernel",
    "key_shift",
    "path_mode_up_kernel",
    "popcount64",
    "right_window_map",
    "select_windows_kernel",
    "similarity_cost_kernel",
    "wta_kernel",
]
