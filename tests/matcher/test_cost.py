"""Cost volumes and their aggregation, against brute force."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.census import census_transform, hamming
from matcher.cost import AGG_SENTINEL, COST_SENTINEL, aggregate_cost, cost_volume


def brute_cost(cl: np.ndarray, cr: np.ndarray, n_disp: int) -> np.ndarray:
    h, w, _ = cl.shape
    out = np.full((h, n_disp, w), COST_SENTINEL, np.uint16)
    for d in range(n_disp):
        for x in range(d, w):
            out[:, d, x] = hamming(cl[:, x], cr[:, x - d])
    return out


def brute_aggregate(cost: np.ndarray, size: int) -> np.ndarray:
    h = size // 2
    n_rows, n_disp, width = cost.shape
    out = np.full(cost.shape, AGG_SENTINEL, np.uint32)
    for d in range(n_disp):
        for y in range(n_rows):
            for x in range(d, width):
                total = 0
                for j in range(-h, h + 1):
                    for i in range(-h, h + 1):
                        yy = min(max(y + j, 0), n_rows - 1)
                        xx = min(max(x + i, d), width - 1)  # replicate inside the valid region
                        total += int(cost[yy, d, xx])
                out[y, d, x] = total
    return out


@pytest.fixture
def codes():
    rng = np.random.default_rng(5)
    left = rng.integers(0, 255, (9, 17)).astype(np.uint8)
    right = rng.integers(0, 255, (9, 17)).astype(np.uint8)
    return census_transform(left, window=9), census_transform(right, window=9)


def test_cost_volume_equals_brute_force(codes):
    cl, cr = codes
    cv = cost_volume(cl, cr, max_disparity=6)
    assert cv.shape == (9, 6, 17) and cv.dtype == np.uint16
    np.testing.assert_array_equal(cv, brute_cost(cl, cr, 6))


def test_cost_volume_hand_example():
    cl = np.zeros((1, 3, 1), np.uint64)
    cr = np.array([[[0b111], [0b1], [0]]], np.uint64)
    cv = cost_volume(cl, cr, max_disparity=2)
    assert cv[0].tolist() == [[3, 1, 0], [65535, 3, 1]]


def test_identical_codes_cost_zero_at_d0(codes):
    cl, _ = codes
    assert not cost_volume(cl, cl, max_disparity=4)[:, 0].any()


def test_aggregate_equals_brute_force(codes):
    cv = cost_volume(*codes, max_disparity=5)
    for size in (3, 5):
        np.testing.assert_array_equal(aggregate_cost(cv, size=size), brute_aggregate(cv, size))


def test_errors(codes):
    cl, cr = codes
    with pytest.raises(TypeError, match="codes_left"):
        cost_volume(cl.astype(np.int64), cr, max_disparity=3)
    with pytest.raises(ValueError, match="same shape"):
        cost_volume(cl[:, :-1], cr, max_disparity=3)
    with pytest.raises(ValueError, match="max_disparity"):
        cost_volume(cl, cr, max_disparity=17)
    with pytest.raises(ValueError, match="size"):
        aggregate_cost(cost_volume(cl, cr, max_disparity=3), size=4)
