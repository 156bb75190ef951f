"""Hand examples and bad input for CTHW (matcher.cthw)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from matcher import match
from matcher.cthw import hh_edges, match_cthw, modify_disparity

INF = np.inf


def test_path_search_hand_example():
    # 5 x 5 disparities; edges (x) form a wall at column 2 except row 4.
    d = np.array(
        [[1, 1, 9, 4, 4],
         [1, 1, 9, 4, 4],
         [3, 1, 9, 4, 4],
         [1, 1, 9, 4, 4],
         [1, 7, 7, 7, 4]], np.float32)
    e = np.zeros((5, 5), bool)
    e[0:4, 2] = True
    out = modify_disparity(d, e)
    # (2, 0): self 3; left none; right 1 (stops at the wall); up 1, 1; down 1, 1 -> 1
    assert out[2, 0] == 1
    # (4, 2): row 4 has no edge: 1, 7, 7, 7, 4 (self 7 counted once); up: wall at (3, 2) -> 7
    assert out[4, 2] == 7
    # (0, 3): self 4, left: wall; right 4; down 4, 4, 4, 7 -> 4
    assert out[0, 3] == 4
    # edge pixel (1, 2): self 9, left 1, 1, right 4, 4, up/down: walls -> tie 1 vs 4 -> smaller
    assert out[1, 2] == 1


def test_path_search_options():
    d = np.array([[5, 2, 2, 6, 6, 6]], np.float32)
    e = np.array([[False, False, False, True, False, False]])
    # pixel 0: self 5, right 2, 2 (stops before the edge at 3) -> 2
    assert modify_disparity(d, e)[0, 0] == 2
    # with include_edge the edge's 6 is counted: 2, 2 vs 6 -> still 2; max_path=1: 5 vs 2 -> 2
    assert modify_disparity(d, e, include_edge=True)[0, 0] == 2
    assert modify_disparity(d, e, max_path=1).tolist()[0][:2] == [2.0, 2.0]
    # without self, pixel 4 sees 6 (right) only; with include_edge also the edge's 6
    assert modify_disparity(d, e, include_self=False)[0, 4] == 6
    # invalid pixels are never counted; all invalid -> inf
    assert modify_disparity(np.full((2, 2), INF, np.float32), np.zeros((2, 2), bool)).tolist() == [
        [INF, INF], [INF, INF]]


def test_modify_disparity_bad_input():
    with pytest.raises(ValueError, match="disparity"):
        modify_disparity(np.array([[1.5]]), np.zeros((1, 1), bool))
    with pytest.raises(ValueError, match="edges"):
        modify_disparity(np.zeros((2, 2)), np.zeros((2, 3), bool))
    with pytest.raises(ValueError, match="max_path"):
        modify_disparity(np.zeros((2, 2)), np.zeros((2, 2), bool), max_path=0)


def test_hh_edges_threshold_modes():
    hh = np.array([[0.0, -8.0, 3.0, 4.0]])
    assert hh_edges(hh, threshold=4.0).tolist() == [[False, True, False, False]]
    assert hh_edges(hh, threshold=0.25, relative=True).tolist() == [[False, True, True, True]]
    with pytest.raises(ValueError, match="threshold"):
        hh_edges(hh, threshold=2.0, relative=True)
    with pytest.raises(ValueError, match="threshold"):
        hh_edges(hh, threshold=-1.0)


def _textured(shape, seed, smooth=0.7):
    img = gaussian_filter(np.random.default_rng(seed).random(shape), smooth)
    return np.round((img - img.min()) / (img.max() - img.min()) * 255).astype(np.uint8)


@pytest.mark.parametrize("shift", [4, 6, 10])
def test_cthw_recovers_an_even_shift_within_one_pixel(shift):
    right = _textured((48, 64 + 16), seed=shift)
    left = np.roll(right, shift, axis=1)
    res = match_cthw(left, right, window=5, max_disparity=16)
    inner = res.disparity[4:-4, 16:-4]
    assert np.mean(np.abs(inner - shift) <= 1) > 0.95
    assert res.disparity.dtype == np.float32 and res.disparity.shape == left.shape
    assert set(np.unique(res.disparity[np.isfinite(res.disparity)])) <= set(range(0, 16, 2))


def test_cthw_odd_size_and_coarse_match_is_ct_on_ll():
    right = _textured((33, 47), seed=1)
    left = np.roll(right, 4, axis=1)
    res = match_cthw(left, right, window=3, max_disparity=9, norm="average")
    assert res.disparity.shape == (33, 47)
    assert res.coarse.shape == res.hh_edges.shape == (17, 24)
    assert res.params["half_max_disparity"] == 5
    from matcher.haar import haar2d

    ll = match(haar2d(left, norm="average").ll, haar2d(right, norm="average").ll, window=3,
               max_disparity=5)
    assert np.array_equal(res.coarse, ll.disparity)
    assert res.ops == ll.ops
    ct = res.params["ct_ops"]
    assert ct.census_comparisons == 2 * 33 * 47 * 8
    assert res.ops.census_comparisons < ct.census_comparisons / 3


def test_norm_does_not_change_the_result():
    right = _textured((32, 48), seed=2)
    left = np.roll(right, 2, axis=1)
    a = match_cthw(left, right, window=5, max_disparity=8, norm="orthonormal")
    b = match_cthw(left, right, window=5, max_disparity=8, norm="average")
    assert np.array_equal(a.disparity, b.disparity) and np.array_equal(a.hh_edges, b.hh_edges)


@pytest.mark.parametrize(
    ("kwargs", "exc", "name"),
    [
        ({"window": 4}, ValueError, "window"),
        ({"window": 31}, ValueError, "window"),
        ({"max_disparity": 0}, ValueError, "max_disparity"),
        ({"hh_threshold": -1.0}, ValueError, "hh_threshold"),
        ({"hh_threshold": "4"}, TypeError, "hh_threshold"),
        ({"norm": "l1"}, ValueError, "norm"),
        ({"pattern": "ring"}, ValueError, "pattern"),
        ({"max_path": 0}, ValueError, "max_path"),
        ({"include_edge": 1}, TypeError, "include_edge"),
    ],
)
def test_match_cthw_bad_input(kwargs, exc, name):
    img = _textured((32, 48), seed=3)
    args = {"window": 5, "max_disparity": 8} | kwargs
    with pytest.raises(exc, match=name):
        match_cthw(img, img, **args)


@pytest.mark.parametrize("shape", [(32, 48), (33, 47)])
@pytest.mark.parametrize("norm", ["orthonormal", "average"])
@pytest.mark.parametrize("pattern", ["dense", "sparse"])
def test_uint8_integer_haar_path_equals_the_float_path(shape, norm, pattern):
    # uint8 views take the integer path (uint16 Haar sums, integer census); float64 copies of
    # the same views take haar2d + match on the float LL band: the results are bit-identical
    right = _textured(shape, seed=3)
    left = np.roll(right, 4, axis=1)
    a = match_cthw(left, right, window=5, max_disparity=10, norm=norm, pattern=pattern)
    b = match_cthw(left.astype(np.float64), right.astype(np.float64), window=5,
                   max_disparity=10, norm=norm, pattern=pattern)
    assert np.array_equal(a.disparity, b.disparity)
    assert np.array_equal(a.coarse, b.coarse) and np.array_equal(a.hh_edges, b.hh_edges)
    assert a.ops == b.ops


def test_haar_padded_kernel_matches_haar2d():
    from matcher._kernels import haar_padded_kernel
    from matcher.haar import haar2d

    img = np.array([[4, 2, 9], [0, 2, 1], [255, 0, 7]], np.uint8)
    ll = np.empty((2, 2), np.uint16)  # r = 0: no padding
    hh = np.empty((2, 2), np.int16)
    haar_padded_kernel(img, img, 0, -1.0, ll, np.empty_like(ll), hh, np.zeros((2, 2), bool))
    bands = haar2d(img, norm="average")
    assert ll.tolist() == [[8, 20], [510, 28]]  # odd sides replicate: 7 + 7 + 7 + 7
    assert np.array_equal(ll, bands.ll * 4) and np.array_equal(hh, bands.hh * 4)
