"""Hand examples and bad input for AWCT / AWSCT (matcher.adaptive)."""

from __future__ import annotations

import numpy as np
import pytest

from matcher import match
from matcher.adaptive import match_awct, match_awsct, select_windows


def _line_map(n_decreases, max_window=11):
    e = np.zeros((40, 40), bool)
    e[:, 20] = True  # a full-height vertical edge line
    return select_windows(e, max_window=max_window, n_decreases=n_decreases)


def test_no_edges_gives_the_largest_window_everywhere():
    m = select_windows(np.zeros((12, 9), bool), max_window=7, n_decreases=5)
    assert m.dtype == np.uint8 and np.all(m == 7)


def test_vertical_line_hand_computed_n2():
    # Row 20, distance k = |x - 20| from the line. A window of side s = 2r + 1 holds the line iff
    # r >= k, then s edge pixels: proportion 1/s, decreasing at every step; 0 before.
    # N = 2: k = 0, 1 -> 3, 5, 7 (two decreases) -> 7; k = 2 -> first at 5, then 7, 9 -> 9;
    # k = 3 -> 11; k = 4 -> enters at 9, one decrease by 11 -> largest (11); k >= 6 -> no edge.
    row = _line_map(2)[20]
    expected = {0: 7, 1: 7, 2: 9, 3: 11, 4: 11, 5: 11, 6: 11, 12: 11}
    for k, side in expected.items():
        assert row[20 + k] == side and row[20 - k] == side, k


def test_vertical_line_hand_computed_n1():
    row = _line_map(1)[20]
    expected = {0: 5, 1: 5, 2: 7, 3: 9, 4: 11, 5: 11}
    for k, side in expected.items():
        assert row[20 + k] == side, k


def test_paper_default_n5_never_chooses_below_13():
    rng = np.random.default_rng(3)
    m = select_windows(rng.random((48, 48)) < 0.05, max_window=21, n_decreases=5)
    assert m.min() >= 13


def test_min_window_changes_the_start_of_the_count():
    # starting at 5 the centre of the line sees 5 -> 7 -> 9 for N = 2
    e = np.zeros((40, 40), bool)
    e[:, 20] = True
    m = select_windows(e, max_window=11, n_decreases=2, min_window=5)
    assert m[20, 20] == 9


@pytest.mark.parametrize(
    ("kwargs", "exc", "name"),
    [
        ({"n_decreases": 0}, ValueError, "n_decreases"),
        ({"n_decreases": 2.0}, TypeError, "n_decreases"),
        ({"max_window": 20}, ValueError, "max_window"),
        ({"max_window": 1}, ValueError, "max_window"),
        ({"min_window": 4}, ValueError, "min_window"),
        ({"min_window": 9, "max_window": 7}, ValueError, "min_window, max_window"),
    ],
)
def test_select_windows_bad_parameters(kwargs, exc, name):
    with pytest.raises(exc, match=name):
        select_windows(np.zeros((20, 20), bool), **kwargs)


def test_select_windows_rejects_non_bool_edges():
    with pytest.raises(TypeError, match="edges"):
        select_windows(np.zeros((20, 20), np.uint8))


def _textured_pair(shift, shape=(40, 64), seed=0):
    rng = np.random.default_rng(seed)
    right = rng.integers(0, 256, shape, dtype=np.uint8)
    return np.roll(right, shift, axis=1), right


def test_no_edges_equals_ct_at_the_largest_window_bit_exactly():
    left, right = _textured_pair(4)
    none = np.zeros(left.shape, bool)
    for method, fn in (("ct", match_awct), ("sct", match_awsct)):
        res = fn(left, right, max_window=9, max_disparity=12, edges=none)
        ct = match(left, right, method=method, window=9, max_disparity=12)
        assert np.array_equal(res.disparity, ct.disparity)
        assert res.ops == ct.ops and res.reduction_ratio == 0.0
        assert np.all(res.window_map == 9)


def test_awct_recovers_a_shift_and_counts_fewer_operations():
    left, right = _textured_pair(5)
    res = match_awct(left, right, max_window=11, max_disparity=12, n_decreases=1,
                     right_windows="left_map")
    assert np.median(res.disparity[:, 16:]) == 5.0
    assert res.method == "awct" and res.window == 11 and res.edges.any()
    ct_ops = res.params["ct_ops"]
    assert res.ops.census_comparisons < ct_ops.census_comparisons
    assert res.ops.hamming_words <= ct_ops.hamming_words
    bits = np.where(res.window_map > 0, res.window_map.astype(np.int64) ** 2 - 1, 0)
    assert res.ops.census_comparisons == 2 * int(bits.sum())
    assert res.reduction_ratio == pytest.approx(1 - bits.mean() / 120)


def test_single_window_size_is_plain_ct_whatever_the_edges():
    left, right = _textured_pair(3)
    e = np.random.default_rng(1).random(left.shape) < 0.3
    res = match_awct(left, right, min_window=7, max_window=7, max_disparity=8, edges=e)
    ct = match(left, right, window=7, max_disparity=8)
    assert np.array_equal(res.disparity, ct.disparity) and res.ops == ct.ops


def test_left_pixel_right_map_is_the_largest_left_window_compared():
    # one row of left windows; with D = 3 the right pixel q meets left pixels q, q+1, q+2
    e = np.zeros((20, 20), bool)
    e[10, 10] = True
    left, right = _textured_pair(1, shape=(20, 20))
    res = match_awct(left, right, max_window=9, max_disparity=3, n_decreases=1, edges=e)
    row_l = res.window_map[10, 6:15].tolist()
    assert row_l == [9, 9, 7, 5, 5, 5, 7, 9, 9]
    assert res.window_map_right[10, 6:15].tolist() == [9, 9, 7, 5, 7, 9, 9, 9, 9]
    bits = res.window_map.astype(np.int64) ** 2 - 1
    bits_r = res.window_map_right.astype(np.int64) ** 2 - 1
    assert res.ops.census_comparisons == int(bits.sum() + bits_r.sum())


def test_right_edges_option_uses_the_right_images_edges():
    left, right = _textured_pair(2)
    a = match_awct(left, right, max_window=9, max_disparity=8, right_windows="right_edges")
    assert a.window_map_right.shape == left.shape
    assert a.params["right_windows"] == "right_edges"
    with pytest.raises(ValueError, match="right_windows"):
        match_awct(left, right, max_window=9, max_disparity=8, right_windows="both")


def test_match_awct_bad_input():
    left, right = _textured_pair(2)
    with pytest.raises(ValueError, match="n_decreases"):
        match_awct(left, right, max_window=9, max_disparity=8, n_decreases=0)
    with pytest.raises(ValueError, match="max_window"):
        match_awct(left, right, max_window=10, max_disparity=8)
    with pytest.raises(ValueError, match="max_disparity"):
        match_awct(left, right, max_window=9, max_disparity=64)
    with pytest.raises(ValueError, match="edges"):
        match_awct(left, right, max_window=9, max_disparity=8, edges=np.zeros((3, 3), bool))
    with pytest.raises(ValueError, match="left and right"):
        match_awct(left, right[:, :-1], max_window=9, max_disparity=8)


def _kernel_run(left, right, wmap_l, wmap_r, max_window, d, left_only):
    """adaptive_wta_kernel with given window maps; (disparity, totals)."""
    import numba

    from matcher._kernels import adaptive_wta_kernel
    from matcher.adaptive import _code_tables
    from matcher.census import padded_grey

    bits_of, offsets = _code_tables(3, max_window, "dense")
    out = np.empty(left.shape, np.float32)
    totals = np.empty((left.shape[0], 4), np.int64)
    adaptive_wta_kernel(
        padded_grey(left, max_window), padded_grey(right, max_window), offsets, max_window // 2,
        wmap_l.copy(), wmap_r.copy(), bits_of, d, left_only, np.empty((0, 0), np.int32), 0,
        np.arange(3, max_window + 1, 2), 5, 0, numba.get_num_threads(), np.zeros(1, np.int64),
        out, totals,
    )
    return out, totals


def test_left_only_kernel_path_equals_the_masked_path():
    # "left_pixel" maps satisfy bits_r >= bits_l for every candidate, so both kernel paths
    # apply: plain costs + re-scored small-window pixels, and per-word prefix masks
    from matcher._kernels import right_window_map

    left, right = _textured_pair(4, shape=(30, 44))
    rng = np.random.default_rng(7)
    wmap = rng.choice(np.array([3, 5, 7, 9], np.uint8), size=left.shape, p=[0.1, 0.1, 0.1, 0.7])
    wmap[::3] = 9  # rows where every pixel has the largest window (the plain path)
    wmap_r = np.empty_like(wmap)
    right_window_map(wmap, 6, wmap_r)
    fast, t_fast = _kernel_run(left, right, wmap, wmap_r, 9, 6, True)
    masked, t_masked = _kernel_run(left, right, wmap, wmap_r, 9, 6, False)
    assert np.array_equal(fast, masked) and np.array_equal(t_fast, t_masked)
    bits = wmap.astype(np.int64) ** 2 - 1
    assert np.array_equal(t_fast[:, 2], bits.sum(axis=1))


def test_result_window_maps_equal_select_windows_and_the_sliding_maximum():
    left, right = _textured_pair(5, shape=(36, 40))
    e = np.random.default_rng(2).random(left.shape) < 0.08
    d = 5
    for right_windows in ("left_pixel", "left_map"):
        res = match_awct(left, right, max_window=11, max_disparity=d, n_decreases=2, edges=e,
                         right_windows=right_windows)
        expected = select_windows(e, max_window=11, n_decreases=2)
        assert np.array_equal(res.window_map, expected)
        if right_windows == "left_map":
            assert np.array_equal(res.window_map_right, expected)
        else:
            w = e.shape[1]
            brute = np.array([[row[q : q + d].max() for q in range(w)] for row in expected])
            assert np.array_equal(res.window_map_right, brute)


def test_right_window_map_hand_example():
    from matcher._kernels import right_window_map

    row = np.array([[3, 9, 5, 5, 7, 3, 3]], np.uint8)
    out = np.empty_like(row)
    right_window_map(row, 3, out)
    assert out.tolist() == [[9, 9, 7, 7, 7, 3, 3]]
    right_window_map(row, 1, out)
    assert out.tolist() == row.tolist()


def test_canny_impl_option():
    left, right = _textured_pair(6)
    a = match_awct(left, right, max_window=9, max_disparity=8, canny_impl="skimage")
    from matcher.edges import canny_edges

    assert np.array_equal(a.edges, canny_edges(left, impl="skimage"))
    assert a.params["canny_impl"] == "skimage"
    assert match_awct(left, right, max_window=9, max_disparity=8).params["canny_impl"] == "opencv"
    with pytest.raises(ValueError, match="canny_impl"):
        match_awct(left, right, max_window=9, max_disparity=8, canny_impl="cv2")


def test_edges_follow_the_input_dtype_range():
    # Canny's thresholds are fractions of the input dtype's range: a uint16 copy scaled by 257
    # (same image, 0..65535) must choose the same edges, windows and disparities as the uint8
    left, right = _textured_pair(6)
    a = match_awct(left, right, max_window=9, max_disparity=8)
    b = match_awct(left.astype(np.uint16) * 257, right.astype(np.uint16) * 257, max_window=9,
                   max_disparity=8)
    assert a.edges.any()
    assert np.array_equal(a.edges, b.edges) and np.array_equal(a.window_map, b.window_map)
    assert np.array_equal(a.disparity, b.disparity)
