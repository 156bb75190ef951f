"""Property tests of the winner-takes-all kernel against the numpy code it replaced, beside hand
examples (ties, both dtypes, D past W, volumes whose entries x - d < 0 are not the sentinel)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from matcher.select import winner_takes_all


def numpy_right_costs(cost: np.ndarray) -> np.ndarray:
    """The cost volume seen from the right view: ``out[y, d, xr] = cost[y, d, xr + d]``."""
    sentinel = np.iinfo(cost.dtype).max
    out = np.full(cost.shape, sentinel, dtype=cost.dtype)
    width = cost.shape[2]
    for d in range(min(cost.shape[1], width)):
        out[:, d, : width - d] = cost[:, d, d:]
    return out


def numpy_wta(cost, *, lr_check=False, lr_tolerance=1, subpixel=False) -> np.ndarray:
    """The numpy implementation ``winner_takes_all`` had before its numba kernel, verbatim."""
    n_rows, n_disp, width = cost.shape
    d_left = np.argmin(cost, axis=1)  # first minimum: ties -> smallest d
    out = d_left.astype(np.float64)
    if subpixel:
        ys, xs = np.indices(d_left.shape)
        ok = (d_left >= 1) & (d_left <= n_disp - 2) & (xs - d_left - 1 >= 0)
        dm = np.clip(d_left - 1, 0, n_disp - 1)
        dp = np.clip(d_left + 1, 0, n_disp - 1)
        cm = cost[ys, dm, xs].astype(np.float64)
        cp = cost[ys, dp, xs].astype(np.float64)
        c0 = cost[ys, d_left, xs].astype(np.float64)
        den = cm - 2.0 * c0 + cp
        ok &= den > 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            offset = (cm - cp) / (2.0 * den)
        out = np.where(ok, out + offset, out)
    if lr_check:
        d_right = np.argmin(numpy_right_costs(cost), axis=1)
        xs = np.arange(width)[None, :]
        partner = np.take_along_axis(d_right, xs - d_left, axis=1)
        out[np.abs(d_left - partner) > lr_tolerance] = np.inf
    return out.astype(np.float32)


def assert_same(cost: np.ndarray, **options) -> None:
    got = winner_takes_all(cost, **options)
    want = numpy_wta(cost, **options)
    assert got.dtype == np.float32 and got.shape == want.shape
    # bit for bit: the same float32 patterns, inf where the LR check fails
    np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))


@st.composite
def cost_volumes(draw, *, sentinel: bool) -> np.ndarray:
    """Small (H, D, W) uint16 or uint32 volumes, D from 1 to past W, with few cost levels (many
    ties) or the whole range. With ``sentinel``, entries ``x - d < 0`` hold the dtype's maximum
    as the public functions write it; without, they hold anything."""
    dtype = draw(st.sampled_from([np.uint16, np.uint32]))
    top = int(np.iinfo(dtype).max)
    h = draw(st.integers(1, 6))
    w = draw(st.integers(1, 20))
    d = draw(st.integers(1, w + 3))
    high = draw(st.sampled_from([2, 7, top]))
    cost = draw(hnp.arrays(dtype, (h, d, w), elements=st.integers(0, high),
                           fill=st.sampled_from([0, 1, high, top])))
    if sentinel:
        for k in range(min(d, w + 1)):
            cost[:, k, :k] = top
        cost[:, w:] = top
    return cost


options = st.fixed_dictionaries({
    "lr_check": st.booleans(),
    "lr_tolerance": st.integers(0, 3),
    "subpixel": st.booleans(),
})


@given(cost=cost_volumes(sentinel=True), options=options)
def test_wta_equals_the_numpy_code(cost, options):
    assert_same(cost, **options)


@given(cost=cost_volumes(sentinel=False), options=options)
def test_wta_equals_the_numpy_code_without_sentinels(cost, options):
    # entries x - d < 0 are read as numpy read them: a small one there wins, its partner wraps
    try:
        want = numpy_wta(cost, **options)
    except IndexError:
        with pytest.raises(IndexError, match="no right partner"):
            winner_takes_all(cost, **options)
        return
    got = winner_takes_all(cost, **options)
    np.testing.assert_array_equal(got.view(np.uint32), want.view(np.uint32))


def test_wta_hand_examples():
    rng = np.random.default_rng(4)
    # a real-sized row block of an aggregated volume: ties, parabolas and LR failures
    cost = rng.integers(0, 40, (6, 64, 640)).astype(np.uint32)
    for d in range(64):
        cost[:, d, :d] = 0xFFFFFFFF
    for lr_check in (False, True):
        for subpixel in (False, True):
            assert_same(cost, lr_check=lr_check, subpixel=subpixel)
    assert np.isinf(winner_takes_all(cost, lr_check=True, lr_tolerance=0)).any()
    # uint16, D past W, every candidate tied: d = 0 everywhere, the LR check passes
    flat = np.full((2, 9, 5), 65535, np.uint16)
    flat[:, 0] = 3
    for d in range(1, 5):
        flat[:, d, d:] = 3
    assert_same(flat, lr_check=True, subpixel=True)
    assert not winner_takes_all(flat, lr_check=True, subpixel=True).any()
    # a small cost at x - d < 0 wins (as in numpy) and its partner column wraps to x - d + W
    odd = np.full((1, 3, 4), 9, np.uint16)
    odd[0, 2, 0] = 0
    assert_same(odd, lr_check=True, lr_tolerance=0)
    assert winner_takes_all(odd)[0, 0] == 2.0
    # a largest tolerance accepts everything; a non-contiguous view reads as its copy
    assert_same(cost, lr_check=True, lr_tolerance=10**30)
    assert_same(cost[::2, :, ::-1], lr_check=True, subpixel=True)


def test_parabola_rounds_once_to_float32():
    # d + offset rounded once (float64, then float32) is 2.5005705; rounding the offset to
    # float32 first would give 2.5005703
    cm, c0, cp = 313304721, 312465760, 1782382099
    cost = np.full((1, 5, 5), 0xFFFFFFFF, np.uint32)
    cost[0, :, 4] = [0xFFFFFFF0, 0xFFFFFFF0, cm, c0, cp]
    exact = np.float32(3.0 + (cm - cp) / (2.0 * (cm - 2.0 * c0 + cp)))
    assert exact != np.float32(3.0 + float(np.float32((cm - cp) / (2.0 * (cm - 2.0 * c0 + cp)))))
    assert winner_takes_all(cost, subpixel=True)[0, 4] == exact
    assert_same(cost, subpixel=True)


def test_wta_without_disparities():
    with pytest.raises(ValueError, match="at least one disparity"):
        winner_takes_all(np.zeros((2, 0, 3), np.uint16))
