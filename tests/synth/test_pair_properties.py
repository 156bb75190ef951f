"""Property: the occlusion mask of a fronto-parallel foreground strip over a background.

Hand-picked example beside it: ``test_pair.py::test_occlusion_mask_hand_picked_row``.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from synth.pair import MASK_INVALID, MASK_OCCLUDED, MASK_VISIBLE, occlusion_mask

W = 48


@given(
    d_back=st.floats(0.0, 10.0),
    gap=st.floats(1.5, 20.0),
    s0=st.floats(-5.0, 40.0),
    length=st.floats(1.0, 30.0),
)
def test_strip_over_background(d_back: float, gap: float, s0: float, length: float) -> None:
    """A strip covering left x in [s0, s1) at disparity d_f hides the background at
    right x in [s0 - d_f, s1 - d_f). The mask must match the geometry exactly except
    where x - d lies within one pixel of the strip's edges in the right view (there the
    right samples cannot tell which surface covers x - d)."""
    d_f, s1 = d_back + gap, s0 + length
    x = np.arange(W, dtype=np.float64)
    in_left = (x >= s0) & (x < s1)
    in_right = (x >= s0 - d_f) & (x < s1 - d_f)
    dl = np.where(in_left, d_f, d_back)[None, :]
    dr = np.where(in_right, d_f, d_back)[None, :]
    mask = occlusion_mask(dl, dr)[0]

    xr = x - dl[0]
    outside = xr < -0.5
    hidden = ~in_left & (xr >= s0 - d_f) & (xr < s1 - d_f)
    truth = np.where(outside | hidden, MASK_OCCLUDED, MASK_VISIBLE)
    ambiguous = ~outside & (
        (np.abs(xr - (s0 - d_f)) < 1.0) | (np.abs(xr - (s1 - d_f)) < 1.0))
    np.testing.assert_array_equal(mask[~ambiguous], truth[~ambiguous])
    assert MASK_INVALID not in mask  # every pixel has a surface
