"""matcher._kernels.cthw: padded Haar sums, the fused path search + upsampling, vote keys."""

from __future__ import annotations

import numpy as np
import pytest

from matcher._kernels import haar_padded_kernel, key_shift, path_mode_up_kernel
from matcher.cthw import hh_edges, modify_disparity
from matcher.haar import haar2d


def _haar_padded(left, right, r, thr):
    h2, w2 = (left.shape[0] + 1) // 2, (left.shape[1] + 1) // 2
    pl = np.empty((h2 + 2 * r, w2 + 2 * r), np.uint16)
    pr = np.empty_like(pl)
    hh = np.empty((h2, w2), np.int16)
    edges = np.zeros((h2, w2), np.bool_)
    haar_padded_kernel(left, right, r, thr, pl, pr, hh, edges)
    return pl, pr, hh, edges


@pytest.mark.parametrize("shape", [(6, 8), (7, 9), (5, 12)])
def test_haar_padded_equals_padded_sums_and_hh_edges(shape):
    rng = np.random.default_rng(1)
    left = rng.integers(0, 256, shape, dtype=np.uint8)
    right = rng.integers(0, 256, shape, dtype=np.uint8)
    pl, pr, hh, edges = _haar_padded(left, right, 2, 4.0)
    for img, padded in ((left, pl), (right, pr)):
        bands = haar2d(img, norm="average")  # the sums are 4x the "average" bands, exactly
        assert np.array_equal(padded, np.pad(bands.ll * 4, 2, mode="edge"))
        if img is left:
            assert np.array_equal(hh, bands.hh * 4)
    assert np.array_equal(edges, hh_edges(hh * 0.25, threshold=4.0))


def test_haar_padded_hand_example_and_no_edges_when_threshold_negative():
    left = np.array([[4, 2], [0, 2]], np.uint8)  # sums: ll = 8, hh = 4 - 2 - 0 + 2 = 4
    pl, _, hh, edges = _haar_padded(left, left, 1, -1.0)
    assert pl.tolist() == [[8, 8, 8]] * 3 and hh.tolist() == [[4]]
    assert not edges.any()  # thr < 0: left untouched (zeros here)
    _, _, _, edges = _haar_padded(left, left, 1, 0.5)  # |4 * 0.25| = 1 > 0.5
    assert edges.tolist() == [[True]]


def _path_up(disp, edges, out_shape, *, up, key_dtype=np.int32, block=3, **kw):
    n_disp = max(1, int(np.where(np.isfinite(disp), disp, -1).max()) + 1)
    out = np.full(out_shape, -7.0, np.float32)
    path_mode_up_kernel(
        disp, edges, n_disp, key_shift(n_disp), kw.get("include_edge", False),
        kw.get("include_self", True), disp.shape[0] + disp.shape[1], block, up,
        np.empty(0, key_dtype), out,
    )
    return out


def test_upsampled_path_search_equals_the_mode_repeated_and_cropped():
    rng = np.random.default_rng(2)
    disp = rng.integers(0, 5, (5, 7)).astype(np.float32)
    disp[1, 2] = np.inf
    edges = rng.random((5, 7)) < 0.3
    mode = modify_disparity(disp, edges)
    for h, w in ((10, 14), (9, 13), (10, 13)):
        got = _path_up(disp, edges, (h, w), up=2)
        ref = np.repeat(np.repeat(2 * mode, 2, axis=0), 2, axis=1)[:h, :w]
        assert np.array_equal(got, ref)


def test_int64_keys_give_the_same_votes():
    rng = np.random.default_rng(4)
    disp = rng.integers(0, 40, (9, 11)).astype(np.float64)
    edges = rng.random((9, 11)) < 0.2
    for kw in ({}, {"include_edge": True}, {"include_self": False}):
        a = _path_up(disp, edges, (9, 11), up=1, **kw)
        b = _path_up(disp, edges, (9, 11), up=1, key_dtype=np.int64, block=11, **kw)
        assert np.array_equal(a, b)
        assert np.array_equal(a, modify_disparity(disp, edges, **kw))


def test_key_shift():
    assert [key_shift(n) for n in (1, 2, 3, 4, 5, 64, 65)] == [0, 1, 2, 2, 3, 6, 7]
