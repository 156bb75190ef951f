"""Properties of match: the fused kernel equals the cost-volume path; shifts are recovered."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matcher import match
from matcher.census import census_transform
from matcher.cost import aggregate_cost, cost_volume
from matcher.select import winner_takes_all
from matcher.testing import grey_images, shifted_pairs


@given(
    left=grey_images(min_side=8, max_side=24, levels=4),
    seed=st.integers(0, 2**16),
    method=st.sampled_from(["ct", "sct"]),
    aggregate=st.sampled_from([None, 3]),
    lr_check=st.booleans(),
    subpixel=st.booleans(),
    data=st.data(),
)
def test_fused_equals_reference(left, seed, method, aggregate, lr_check, subpixel, data):
    right = np.random.default_rng(seed).permutation(left, axis=1)  # same shape, related content
    max_disparity = data.draw(st.integers(1, left.shape[1] - 1), label="max_disparity")
    kwargs = dict(window=3, max_disparity=max_disparity, aggregate=aggregate,
                  lr_check=lr_check, subpixel=subpixel)
    pattern = "dense" if method == "ct" else "sparse"
    cost = cost_volume(census_transform(left, window=3, pattern=pattern),
                       census_transform(right, window=3, pattern=pattern),
                       max_disparity=max_disparity)
    if aggregate is not None:
        cost = aggregate_cost(cost, size=aggregate)
    expected = winner_takes_all(cost, lr_check=lr_check, subpixel=subpixel)
    np.testing.assert_array_equal(match(left, right, method=method, **kwargs).disparity, expected)


@given(pair=shifted_pairs(max_shift=8, min_side=24, max_side=40))
def test_shift_recovered_in_the_textured_interior(pair):
    res = match(pair.left, pair.right, window=7, max_disparity=10)
    inner = res.disparity[3:-3, pair.shift + 3 : -3]
    assert (inner == pair.shift).mean() > 0.95


def test_shift_hand_example():
    rng = np.random.default_rng(9)
    strip = rng.integers(0, 256, (24, 40)).astype(np.uint8)
    left, right = strip[:, :36], strip[:, 4:40]
    inner = match(left, right, window=5, max_disparity=8).disparity[2:-2, 6:-2]
    # 4 of 480 miss: local minima have all-zero codes and tie at several d (smallest d wins)
    assert (inner != 4.0).sum() == 4 and (inner[inner != 4.0] < 4).all()
