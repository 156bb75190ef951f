"""Sparse census patterns: the 7 x 7 reconstruction, symmetry, nesting, drawing."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.census import census_transform
from matcher.patterns import n_bits, sparse_pattern, spiral_offsets

WINDOWS = list(range(3, 23, 2))


def test_7x7_is_the_16_point_odd_lattice():
    pat = sparse_pattern(7)
    assert len(pat) == 16
    assert {tuple(p) for p in pat.tolist()} == {
        (dy, dx) for dy in (-3, -1, 1, 3) for dx in (-3, -1, 1, 3)
    }
    assert pat[:4].tolist() == [[-1, 1], [-1, -1], [1, -1], [1, 1]]  # ring 1 in spiral order


def test_sizes():
    assert [len(sparse_pattern(w)) for w in WINDOWS] == [4, 4, 16, 16, 36, 36, 64, 64, 100, 100]
    assert n_bits(21, "sparse") == 100


@pytest.mark.parametrize("window", WINDOWS)
def test_subset_of_dense_in_spiral_order_and_symmetric(window):
    pat = sparse_pattern(window)
    dense = spiral_offsets(window).tolist()
    positions = [dense.index(p) for p in pat.tolist()]
    assert positions == sorted(positions)  # a subsequence of the dense spiral
    as_set = {tuple(p) for p in pat.tolist()}
    assert {(-dy, -dx) for dy, dx in as_set} == as_set  # point-symmetric


@pytest.mark.parametrize("window", WINDOWS[1:])
def test_smaller_pattern_is_a_prefix(window):
    small = sparse_pattern(window - 2)
    np.testing.assert_array_equal(sparse_pattern(window)[: len(small)], small)


def test_sparse_codes_are_a_prefix_across_windows():
    img = np.random.default_rng(3).integers(0, 255, (25, 25)).astype(np.uint8)
    c7 = census_transform(img, window=7, pattern="sparse")[..., 0]
    c11 = census_transform(img, window=11, pattern="sparse")[..., 0]
    np.testing.assert_array_equal(c7, c11 & np.uint64(0xFFFF))


def test_bad_window():
    with pytest.raises(ValueError, match="window"):
        sparse_pattern(6)
