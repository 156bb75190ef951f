"""Winner-takes-all, left-right check and subpixel on hand-made cost volumes."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.select import winner_takes_all

S = 65535  # sentinel of a uint16 volume


def volume(rows: list[list[int]]) -> np.ndarray:
    """(1, D, W) uint16 volume from D rows of W costs."""
    return np.array([rows], np.uint16)


def test_ties_go_to_the_smallest_d():
    cost = volume([[4, 2, 2, 7], [S, 2, 1, 7], [S, S, 1, 7]])
    assert winner_takes_all(cost).tolist() == [[0.0, 0.0, 1.0, 0.0]]


def test_columns_with_x_minus_d_below_zero_are_never_chosen():
    # the small costs at x < d must not win: a real sentinel-free volume would have them
    cost = volume([[9, 9, 9], [0, 9, 9], [0, 0, 8]])
    cost[0, 1, 0] = cost[0, 2, 0] = cost[0, 2, 1] = S
    assert winner_takes_all(cost).tolist() == [[0.0, 0.0, 2.0]]


def test_lr_check_marks_inconsistent_pixels_inf():
    # left pixel x=2 picks d=2 (right pixel 0), but right pixel 0 prefers d=0 (left pixel 0)
    cost = volume([[1, 5, 3, 5], [S, 5, 5, 0], [S, S, 2, 5]])
    plain = winner_takes_all(cost)
    checked = winner_takes_all(cost, lr_check=True, lr_tolerance=1)
    assert plain.tolist() == [[0.0, 0.0, 2.0, 1.0]]
    assert checked.tolist() == [[0.0, 0.0, np.inf, 1.0]]
    assert winner_takes_all(cost, lr_check=True, lr_tolerance=2).tolist() == plain.tolist()


def test_subpixel_parabola():
    # at x=3, d=1 wins with neighbours 4 (d=0) and 8 (d=2): (4 - 8) / (2 (4 - 2*2 + 8)) = -0.25
    cost = volume([[0, 0, 0, 4], [S, 9, 9, 2], [S, S, 9, 8]])
    out = winner_takes_all(cost, subpixel=True)
    assert out.tolist() == [[0.0, 0.0, 0.0, 0.75]]
    assert out.dtype == np.float32


def test_subpixel_skips_missing_neighbours():
    cost = volume([[S, 5, 3], [S, 9, 1], [S, S, 9]])
    cost[0, 0, 0] = 0
    # x=1: d=0 (no d-1); x=2: d=1 but d+1 needs x-2 >= 0 -> ok: (3-9)/(2*(3-2+9)) = -0.3
    out = winner_takes_all(cost, subpixel=True)
    assert out[0, :2].tolist() == [0.0, 0.0]
    assert out[0, 2] == np.float32(1.0 - 0.3)


def test_errors():
    with pytest.raises(TypeError, match="cost"):
        winner_takes_all(np.zeros((2, 3, 4), np.float32))
    with pytest.raises(ValueError, match="lr_tolerance"):
        winner_takes_all(np.zeros((1, 2, 3), np.uint16), lr_check=True, lr_tolerance=-1)
