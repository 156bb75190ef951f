"""The importable strategies produce what they promise."""

from __future__ import annotations

import numpy as np
from hypothesis import given

from matcher import testing as mst


@given(mst.windows(min_size=3, max_size=21))
def test_windows_are_odd_and_in_range(w):
    assert w % 2 == 1 and 3 <= w <= 21


@given(mst.shifted_pairs(max_shift=6))
def test_shifted_pair_matches_at_its_shift(pair):
    w = pair.left.shape[1]
    assert pair.left.shape == pair.right.shape
    assert np.array_equal(pair.left[:, pair.shift :], pair.right[:, : w - pair.shift])


def test_shifted_pair_hand_example():
    strip = np.arange(10, dtype=np.uint8)[None, :].repeat(2, axis=0)
    left, right = strip[:, :7], strip[:, 3:10]
    # left x matches right x - 3: left[:, 5] == right[:, 2]
    assert left[0, 5] == right[0, 2] == 5


@given(mst.piecewise_planar_pairs(integer=True, max_disparity=6))
def test_integer_planar_pair_is_an_exact_warp(pair):
    h, w = pair.left.shape
    ys, xs = np.mgrid[0:h, 0:w]
    src = xs - pair.disparity.astype(int)
    inside = src >= 0
    assert np.array_equal(pair.left[inside], pair.right[ys[inside], src[inside]])


@given(mst.piecewise_planar_pairs(max_disparity=10))
def test_planar_pieces_are_affine(pair):
    d, labels = pair.disparity, pair.labels
    assert np.all(d >= 0) and np.all(d <= 10)
    for k in np.unique(labels):
        rows = np.unique(np.nonzero(labels == k)[0])
        block = d[rows]
        # second differences of an affine field vanish (away from the clip at 0 / max)
        if np.all((block > 0) & (block < 10)):
            assert np.allclose(np.diff(block, 2, axis=1), 0, atol=1e-9)


@given(mst.monotone_maps())
def test_monotone_maps_are_strictly_increasing(lut):
    assert lut.shape == (256,) and np.all(np.diff(lut) > 0)


@given(mst.grey_images(levels=4))
def test_grey_images_respect_levels(img):
    assert img.dtype == np.uint8 and len(np.unique(img)) <= 4
