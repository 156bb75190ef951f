"""Properties of the adaptive window choice and AWCT/AWSCT, each with a hand-picked example."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matcher import match
from matcher.adaptive import match_awct, select_windows
from matcher.census import census_transform, hamming
from matcher.patterns import n_bits


@st.composite
def edge_maps(draw, min_side=8, max_side=40):
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    density = draw(st.sampled_from([0.0, 0.01, 0.05, 0.2, 0.5]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    return rng.random((h, w)) < density


max_windows = st.sampled_from([5, 7, 9, 11, 13])


@given(edge_maps(), max_windows, st.integers(1, 6))
def test_sizes_come_from_the_allowed_set(edges, max_window, n):
    m = select_windows(edges, max_window=max_window, n_decreases=n)
    assert set(np.unique(m)) <= set(range(3, max_window + 1, 2))


def test_allowed_set_example():
    e = np.zeros((30, 30), bool)
    e[10:20, 15] = True
    m = select_windows(e, max_window=9, n_decreases=1)
    assert set(np.unique(m)) <= {3, 5, 7, 9} and m[15, 15] == 5


@given(edge_maps(min_side=16), max_windows, st.integers(1, 4), st.data())
def test_choice_depends_only_on_edges_inside_the_largest_window(edges, max_window, n, data):
    h, w = edges.shape
    y = data.draw(st.integers(0, h - 1))
    x = data.draw(st.integers(0, w - 1))
    r = max_window // 2
    inside = np.zeros_like(edges)
    inside[max(y - r, 0): y + r + 1, max(x - r, 0): x + r + 1] = True
    noise = np.random.default_rng(data.draw(st.integers(0, 1000))).random(edges.shape) < 0.5
    other = np.where(inside, edges, noise)
    a = select_windows(edges, max_window=max_window, n_decreases=n)[y, x]
    b = select_windows(other, max_window=max_window, n_decreases=n)[y, x]
    assert a == b


def test_locality_example():
    e = np.zeros((30, 30), bool)
    e[5, 5] = True
    far = e.copy()
    far[25:, 25:] = True  # outside the 9 x 9 window around (5, 5)
    assert select_windows(e, max_window=9, n_decreases=1)[5, 5] == select_windows(
        far, max_window=9, n_decreases=1)[5, 5] == 5


@given(edge_maps(), max_windows, st.integers(1, 5))
def test_larger_n_never_gives_a_smaller_window(edges, max_window, n):
    a = select_windows(edges, max_window=max_window, n_decreases=n)
    b = select_windows(edges, max_window=max_window, n_decreases=n + 1)
    assert np.all(b >= a)


def test_larger_n_example():
    e = np.zeros((40, 40), bool)
    e[:, 20] = True
    sides = [int(select_windows(e, max_window=11, n_decreases=n)[20, 20]) for n in (1, 2, 3, 4, 5)]
    assert sides == [5, 7, 9, 11, 11]


def _pair(seed, h, w, shift):
    rng = np.random.default_rng(seed)
    right = rng.integers(0, 256, (h, w), dtype=np.uint8)
    return np.roll(right, shift, axis=1), right


@given(st.integers(0, 2**31), edge_maps(min_side=12, max_side=24), st.sampled_from(["dense", "sparse"]))
def test_ops_at_most_ct_and_equal_iff_every_pixel_uses_the_largest(seed, edges, pattern):
    h, w = edges.shape
    left, right = _pair(seed, h, w, 2)
    res = match_awct(left, right, max_window=9, max_disparity=6, n_decreases=1, edges=edges,
                     pattern=pattern)
    ct = match(left, right, method="ct" if pattern == "dense" else "sct", window=9, max_disparity=6)
    assert res.ops.census_comparisons <= ct.ops.census_comparisons
    assert res.ops.hamming_words <= ct.ops.hamming_words
    all_max = bool(np.all(res.window_map == 9))
    # sparse 7 x 7 and 9 x 9 patterns are equal (even rings hold no lattice point)
    same_bits = np.all([n_bits(int(s), pattern) == n_bits(9, pattern) for s in np.unique(res.window_map)])
    assert (res.ops.census_comparisons == ct.ops.census_comparisons) == bool(same_bits)
    if all_max:
        assert np.array_equal(res.disparity, ct.disparity)


def test_ops_example():
    left, right = _pair(0, 20, 20, 2)
    e = np.zeros((20, 20), bool)
    e[10, 10] = True
    res = match_awct(left, right, max_window=9, max_disparity=6, n_decreases=1, edges=e,
                     right_windows="left_map")
    # ring 1 around the edge (and the edge pixel) sees 1/9 -> 1/25: side 5 (24 bits);
    # ring 2 sees 0 -> 1/25 -> 1/49: side 7 (48 bits); ring 3 and beyond: side 9 (80 bits)
    assert int((res.window_map == 5).sum()) == 9 and int((res.window_map == 7).sum()) == 16
    assert res.ops.census_comparisons == 2 * (20 * 20 * 80 - 9 * (80 - 24) - 16 * (80 - 48))


def _reference_awct(left, right, wmap, wmap_r, max_disparity, pattern):
    """Brute force: each pair compared with the census of the smaller window itself."""
    codes = {int(s): (census_transform(left, window=int(s), pattern=pattern),
                      census_transform(right, window=int(s), pattern=pattern))
             for s in np.unique(np.concatenate([wmap, wmap_r]))}
    h, w = left.shape
    out = np.zeros((h, w), np.float32)
    for y in range(h):
        for x in range(w):
            best, best_d = None, 0
            for d in range(min(max_disparity, x + 1)):
                s = int(min(wmap[y, x], wmap_r[y, x - d]))
                c = int(hamming(codes[s][0][y, x], codes[s][1][y, x - d]))
                if best is None or c < best:
                    best, best_d = c, d
            out[y, x] = best_d
    return out


@given(st.integers(0, 2**31), edge_maps(min_side=10, max_side=16),
       st.sampled_from(["dense", "sparse"]), st.sampled_from(["left_pixel", "left_map"]))
def test_awct_equals_brute_force_with_the_smaller_windows_census(seed, edges, pattern, right_windows):
    h, w = edges.shape
    left, right = _pair(seed, h, w, 1)
    res = match_awct(left, right, max_window=7, max_disparity=5, n_decreases=1, edges=edges,
                     pattern=pattern, right_windows=right_windows)
    ref = _reference_awct(left, right, res.window_map, res.window_map_right, 5, pattern)
    assert np.array_equal(res.disparity, ref)
    if right_windows == "left_pixel":  # every candidate is scored over the left pixel's window
        ref_left = _reference_awct(left, right, res.window_map, np.full_like(res.window_map, 7),
                                   5, pattern)
        assert np.array_equal(res.disparity, ref_left)


def test_brute_force_example():
    left, right = _pair(7, 14, 14, 1)
    e = np.zeros((14, 14), bool)
    e[4:10, 7] = True
    res = match_awct(left, right, max_window=7, max_disparity=5, n_decreases=1, edges=e,
                     right_windows="left_map")
    assert len(np.unique(res.window_map)) > 1  # mixed windows, so the prefix rule matters
    assert np.array_equal(res.disparity, _reference_awct(left, right, res.window_map,
                                                         res.window_map, 5, "dense"))


@given(st.integers(0, 2**31), st.integers(12, 30), st.integers(14, 30))
def test_no_edges_equals_ct_bit_exactly(seed, h, w):
    left, right = _pair(seed, h, w, 3)
    res = match_awct(left, right, max_window=9, max_disparity=8, edges=np.zeros((h, w), bool))
    assert np.array_equal(res.disparity, match(left, right, window=9, max_disparity=8).disparity)


@given(st.integers(1, 40), st.integers(1, 40), st.integers(0, 2**32 - 1))
def test_right_window_map_is_the_sliding_maximum(w, d, seed):
    from matcher._kernels import right_window_map

    d = min(d, w)
    rng = np.random.default_rng(seed)
    wmap = rng.choice(np.arange(3, 22, 2).astype(np.uint8), size=(3, w))
    out = np.empty_like(wmap)
    right_window_map(wmap, d, out)
    brute = np.array([[row[q : q + d].max() for q in range(w)] for row in wmap])
    assert np.array_equal(out, brute)


def test_sliding_maximum_example():
    from matcher._kernels import right_window_map

    wmap = np.array([[5, 3, 3, 11, 3, 7]], np.uint8)
    out = np.empty_like(wmap)
    right_window_map(wmap, 2, out)
    assert out.tolist() == [[5, 3, 11, 11, 7, 7]]
