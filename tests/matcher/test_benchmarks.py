"""Hand-picked cases of the benchmark conventions (the real SDK and devkit: tests/clients/)."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.benchmarks import eth3d_two_view, middlebury_v3

# errors exactly 0.5, 1, 2, 4 px (exact in float32): each is good at its own threshold, as
# evaldisp counts a pixel bad when |err| > thresh
_GT = np.full((1, 5), 10.0, np.float32)
_AT_THRESHOLDS = np.array([[10.5, 11.0, 12.0, 14.0, np.inf]], np.float32)


def test_middlebury_bad_x_counts_an_error_equal_to_x_as_good():
    m = middlebury_v3(_AT_THRESHOLDS, _GT, region="all")
    assert (m.bad_0_5, m.bad_1, m.bad_2, m.bad_4) == (60.0, 40.0, 20.0, 0.0)
    assert (m.total_bad_0_5, m.total_bad_4) == (80.0, 20.0)  # + the one hole


def test_eth3d_bad_x_counts_an_error_equal_to_x_as_good():
    m = eth3d_two_view(_AT_THRESHOLDS, _GT, region="all")
    assert (m.bad_0_5, m.bad_1, m.bad_2, m.bad_4) == (75.0, 50.0, 25.0, 0.0)  # of the estimated


@pytest.mark.parametrize("score", [middlebury_v3, eth3d_two_view])
def test_a50_to_a99_are_quantiles_of_the_errors(score):
    gt = np.full((1, 12), 20.0, np.float32)
    est = np.append(20.0 + np.arange(11.0), np.inf).astype(np.float32)[None, :]  # errors 0 .. 10
    m = score(est, gt, region="all")
    assert (m.a50, m.a90, m.a95, m.a99) == pytest.approx((5.0, 9.0, 9.5, 9.9))
