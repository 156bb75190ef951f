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


def _reference_mask(dl: np.ndarray, dr: np.ndarray, lerp_tol: float, edge_tol: float
                    ) -> np.ndarray:
    """``occlusion_mask`` as whole-array numpy expressions (its previous implementation)."""
    dl, dr = np.asarray(dl, dtype=np.float64), np.asarray(dr, dtype=np.float64)
    h, w = dl.shape
    xr = np.arange(w) - dl
    inside = xr >= -0.5
    x0 = np.floor(xr, where=inside, out=np.zeros_like(xr))
    t = xr - x0
    i0 = x0.astype(np.intp)
    a = np.take_along_axis(dr, np.maximum(i0, 0), axis=1)
    b = np.take_along_axis(dr, np.minimum(i0 + 1, w - 1), axis=1)
    with np.errstate(invalid="ignore"):
        ok = (np.abs(dl - (a + t * (b - a))) <= lerp_tol) | (np.abs(dl - a) <= edge_tol)
        ok |= (t > 0) & (np.abs(dl - b) <= edge_tol)
    mask = np.where(np.isfinite(dl), MASK_OCCLUDED, MASK_INVALID).astype(np.uint8)
    mask[inside & ok] = MASK_VISIBLE
    return mask


_disparity = st.sampled_from([0.0, 0.5, 1.0, 2.0, 2.004, 3.0, 7.25, 40.0, np.inf, np.nan])


@given(
    shape=st.tuples(st.integers(1, 6), st.integers(1, 24)),
    data=st.data(),
    tols=st.tuples(st.sampled_from([0.0, 0.01, 0.1]), st.sampled_from([0.0, 0.5, 1.0])),
)
def test_mask_equals_the_whole_array_reference(shape: tuple[int, int], data: st.DataObject,
                                               tols: tuple[float, float]) -> None:
    """The compiled kernel and the numpy expressions agree on every pixel (hand-picked
    example: ``test_pair.py::test_occlusion_mask_special_values``)."""
    n = shape[0] * shape[1]
    dl = np.array(data.draw(st.lists(_disparity, min_size=n, max_size=n))).reshape(shape)
    dr = np.array(data.draw(st.lists(_disparity, min_size=n, max_size=n))).reshape(shape)
    got = occlusion_mask(dl, dr, lerp_tol=tols[0], edge_tol=tols[1])
    np.testing.assert_array_equal(got, _reference_mask(dl, dr, *tols))
