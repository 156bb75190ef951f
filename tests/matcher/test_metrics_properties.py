"""Property tests for the metrics; hand-picked companions are in ``test_metrics.py``."""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from matcher.metrics import evaluate, pobmp, rms

# relative tolerance of float comparisons, keyed by the dtype of the computation (metrics use float64)
RTOL = {np.dtype(np.float32): 1e-6, np.dtype(np.float64): 1e-12}

_shapes = st.tuples(st.integers(1, 16), st.integers(1, 16))
_gt_values = st.floats(0, 200, width=32) | st.just(np.inf) | st.just(np.nan)
_est_values = st.floats(-50, 250, width=32) | st.sampled_from([np.inf, -np.inf, np.nan])


@st.composite
def maps(draw):
    shape = draw(_shapes)
    gt = draw(hnp.arrays(np.float32, shape, elements=_gt_values))
    assume(np.isfinite(gt).any())
    est = draw(hnp.arrays(draw(st.sampled_from([np.float32, np.float64])), shape, elements=_est_values))
    occ = draw(hnp.arrays(np.uint8, shape, elements=st.sampled_from([0, 128, 255])))
    return est, gt, occ


@given(pair=maps(), delta=st.floats(0.01, 300))
def test_percentages_are_in_range_and_ordered(pair, delta):
    est, gt, _ = pair
    m = evaluate(est, gt, delta=delta)
    for value in (m.pobmp, m.bad_0_5, m.bad_1, m.bad_2, m.bad_4, m.d1, m.invalid):
        assert 0.0 <= value <= 100.0
    assert m.bad_0_5 >= m.bad_1 >= m.bad_2 >= m.bad_4 >= m.invalid
    assert m.pobmp >= m.invalid and m.d1 >= m.invalid
    assert m.n_pixels == int(np.isfinite(gt).sum())
    assert pobmp(est, gt, delta=delta) == m.pobmp


@given(pair=maps(), deltas=st.lists(st.floats(0.01, 300), min_size=2, max_size=5))
def test_pobmp_non_increasing_in_delta(pair, deltas):
    est, gt, _ = pair
    values = [pobmp(est, gt, delta=d) for d in sorted(deltas)]
    assert all(a >= b for a, b in zip(values, values[1:]))


@given(pair=maps())
def test_perfect_estimate_scores_zero(pair):
    _, gt, _ = pair
    m = evaluate(gt.copy(), gt)
    assert m.pobmp == m.bad_0_5 == m.d1 == m.invalid == m.rms == m.avgerr == 0.0


@given(pair=maps())
def test_rms_at_least_mean_absolute_error(pair):
    est, gt, _ = pair
    m = evaluate(est, gt)
    if np.isnan(m.avgerr):
        assert np.isnan(m.rms) and m.invalid == 100.0
    else:
        assert m.rms >= m.avgerr * (1 - RTOL[np.dtype(np.float64)])
        assert rms(est, gt) == m.rms


@given(pair=maps())
def test_nonocc_is_a_subset_of_all(pair):
    est, gt, occ = pair
    keep_noc = np.isfinite(gt) & (occ == 255)
    keep_all = np.isfinite(gt) & (occ != 0)
    assume(keep_noc.any())
    m_noc = evaluate(est, gt, region="nonocc", occlusion_mask=occ)
    m_all = evaluate(est, gt, occlusion_mask=occ)
    assert m_noc.n_pixels == int(keep_noc.sum()) <= m_all.n_pixels == int(keep_all.sum())
    # the same pixels selected with a boolean mask give the same numbers
    by_mask = dataclasses.asdict(evaluate(est, gt, mask=occ == 255))
    np.testing.assert_equal(by_mask, dataclasses.asdict(m_noc) | {"region": "all"})  # NaN == NaN here
