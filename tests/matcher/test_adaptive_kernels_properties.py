"""AWCT's per-pixel winner (ties -> smallest d): the int32 key minimum equals a plain search."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matcher._kernels.adaptive import _keys_fit, _last_argmin_keys, _last_argmin_search


def _reference(acc):
    return int(np.flatnonzero(acc == acc.min())[-1])


@given(st.integers(1, 200), st.integers(1, 70), st.integers(0, 2**32 - 1))
def test_key_minimum_is_the_last_minimum(k, top, seed):
    acc = np.random.default_rng(seed).integers(0, top, k).astype(np.int32)
    assert _keys_fit(int(acc.max()), k)
    assert _last_argmin_keys(acc, k) == _last_argmin_search(acc, k) == _reference(acc)


def test_last_minimum_example():
    acc = np.array([5, 2, 7, 2, 9], np.int32)  # minima at 1 and 3: the last one wins
    assert _last_argmin_keys(acc, 5) == _last_argmin_search(acc, 5) == 3
    assert _last_argmin_keys(acc, 2) == 1  # only the first k entries count


def test_keys_fit_bound():
    assert _keys_fit(65024, 64)  # the largest window's bits with 64 candidates
    assert not _keys_fit(2**25, 64)  # 2**25 << 6 overflows int32: the search is used


def _windows_reference(edges, sides, n):
    """The rule of :func:`matcher.adaptive.select_windows`, pixel by pixel, in Python ints."""
    h, w = edges.shape
    out = np.empty((h, w), np.uint8)
    for y in range(h):
        for x in range(w):
            counts = []
            for s in sides:
                r = s // 2
                counts.append(int(edges[max(y - r, 0) : y + r + 1, max(x - r, 0) : x + r + 1].sum()))
            chosen, run = sides[-1], 0
            for k in range(1, len(sides)):
                run = run + 1 if counts[k] * sides[k - 1] ** 2 < counts[k - 1] * sides[k] ** 2 else 0
                if run == n:
                    chosen = sides[k]
                    break
            out[y, x] = chosen
    return out


@given(st.integers(0, 2**32 - 1), st.sampled_from([9, 21, 217, 255]), st.integers(1, 6))
def test_window_choice_equals_the_rule_on_int32_and_int64_counts(seed, largest, n):
    # largest <= 215 runs on int32 products, larger sides on int64 (matcher._kernels.adaptive)
    from matcher.adaptive import select_windows

    rng = np.random.default_rng(seed)
    edges = rng.random((int(rng.integers(1, 9)), int(rng.integers(1, 9)))) < rng.random()
    sides = list(range(3, largest + 1, 2))
    got = select_windows(edges, max_window=largest, n_decreases=n)
    assert np.array_equal(got, _windows_reference(edges, sides, n))


def test_window_choice_example_with_a_wide_largest_side():
    from matcher.adaptive import select_windows

    edges = np.zeros((5, 5), bool)
    edges[2, 2] = True
    # at the centre: 1/9, 1/25, 1/49, ... (every step a decrease): N decreases at side 3 + 2N
    assert select_windows(edges, max_window=217, n_decreases=2)[2, 2] == 7
    # at a corner: 0/9, then 1/25 (an increase), 1/49 (a decrease), ...
    assert select_windows(edges, max_window=217, n_decreases=1)[0, 0] == 7
    assert np.array_equal(
        select_windows(edges, max_window=217, n_decreases=1),
        _windows_reference(edges, list(range(3, 218, 2)), 1),
    )
