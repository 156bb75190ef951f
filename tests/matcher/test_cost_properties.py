"""Property tests of the box aggregation kernel against the numpy code it replaced, beside hand
examples (sizes 3..31, D from 1 to past W, images lower than the box, the largest costs)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from matcher.cost import AGG_SENTINEL, aggregate_cost


def numpy_aggregate(cost: np.ndarray, size: int) -> np.ndarray:
    """The numpy implementation ``aggregate_cost`` had before its numba kernel, verbatim: per
    disparity, an int64 2-D cumulative sum of the edge-padded valid columns ``x >= d``."""
    h = size // 2
    n_rows, n_disp, width = cost.shape
    out = np.full(cost.shape, AGG_SENTINEL, dtype=np.uint32)
    for d in range(min(n_disp, width)):
        valid = cost[:, d, d:].astype(np.int64)
        padded = np.pad(valid, h, mode="edge")
        csum = np.cumsum(np.cumsum(padded, axis=0), axis=1)
        csum = np.pad(csum, ((1, 0), (1, 0)))
        s = size
        box = csum[s:, s:] - csum[:-s, s:] - csum[s:, :-s] + csum[:-s, :-s]
        out[:, d, d:] = box.astype(np.uint32)
    return out


def assert_same(cost: np.ndarray, size: int) -> None:
    got = aggregate_cost(cost, size=size)
    assert got.dtype == np.uint32 and got.shape == cost.shape
    np.testing.assert_array_equal(got, numpy_aggregate(cost, size))


@st.composite
def cost_volumes(draw) -> np.ndarray:
    """Small (H, D, W) uint16 volumes, D from 1 to past W; costs anywhere in 0..65535, with runs
    of one value (often the largest) so that saturated boxes come up."""
    h = draw(st.integers(1, 10))
    w = draw(st.integers(1, 24))
    d = draw(st.integers(1, w + 3))
    high = draw(st.sampled_from([3, 255, 65535]))
    return draw(
        hnp.arrays(
            np.uint16, (h, d, w),
            elements=st.integers(0, high),
            fill=st.sampled_from([0, high, 65534, 65535]),
        )
    )


@given(cost=cost_volumes(), size=st.sampled_from(range(3, 32, 2)))
def test_aggregate_equals_the_numpy_code(cost, size):
    assert_same(cost, size)


def test_aggregate_hand_examples():
    rng = np.random.default_rng(11)
    # one row, a box of 31 rows: every output row reads the same row 31 times
    assert_same(rng.integers(0, 65536, (1, 5, 9), dtype=np.uint16), 31)
    # D past W: the disparities d >= W are all sentinel
    cost = rng.integers(0, 65536, (4, 12, 7), dtype=np.uint16)
    assert_same(cost, 3)
    assert (aggregate_cost(cost, size=3)[:, 7:] == AGG_SENTINEL).all()
    # a 640-wide row of 64 disparities, strips of several rows
    assert_same(rng.integers(0, 65, (40, 64, 640), dtype=np.uint16), 9)
    # largest costs everywhere: 31 x 31 x 65534 = 62 977 174, no uint32 overflow
    full = aggregate_cost(np.full((3, 4, 40), 65534, np.uint16), size=31)
    assert full[1, 3, 39] == 31 * 31 * 65534
    assert_same(np.full((3, 4, 40), 65534, np.uint16), 31)


def test_aggregate_hand_computed():
    # W = 3, D = 2, H = 1, size 3; d = 1 sees the valid columns [1, 2] as 1 2 2 / 1 1 2 padded
    cost = np.array([[[1, 2, 4], [65535, 8, 16]]], np.uint16)
    agg = aggregate_cost(cost, size=3)
    # d = 0, x = 0: rows replicated 3 times, columns (0, 0, 1) -> 3 * (1 + 1 + 2)
    assert agg[0, 0].tolist() == [3 * 4, 3 * 7, 3 * 10]
    assert agg[0, 1].tolist() == [int(AGG_SENTINEL), 3 * (8 + 8 + 16), 3 * (8 + 16 + 16)]


def test_aggregate_takes_non_contiguous_volumes():
    cost = np.random.default_rng(3).integers(0, 65536, (6, 5, 20), dtype=np.uint16)
    view = cost[::2, :, ::-1]
    assert_same(view, 5)
