"""Hand-checked metric values and input validation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from matcher.metrics import Metrics, evaluate, pobmp, rms

INF, NAN = np.inf, np.nan


def test_perfect_map():
    gt = np.array([[1.0, 2.0], [3.0, INF]], np.float32)
    m = evaluate(gt.copy(), gt)
    assert m == Metrics(pobmp=0.0, rms=0.0, avgerr=0.0, bad_0_5=0.0, bad_1=0.0, bad_2=0.0,
                        bad_4=0.0, d1=0.0, invalid=0.0, n_pixels=3, delta=3.0, region="all")


def test_hand_example_all_measures():
    # errors 0, 0.75, 1.5, 3, 3.5, 10 (valid) + one invalid estimate; last gt unknown (excluded)
    gt = np.array([[10, 10, 10, 10, 10, 100, 20, INF]], np.float64)
    est = np.array([[10, 10.75, 8.5, 13, 13.5, 110, NAN, 5]], np.float64)
    m = evaluate(est, gt)
    errors = np.array([0, 0.75, 1.5, 3, 3.5, 10])
    assert m.n_pixels == 7
    assert m.pobmp == pytest.approx(100 * 3 / 7)  # 3.5, 10 and the invalid one; 3 is not > 3
    assert m.bad_0_5 == pytest.approx(100 * 6 / 7)
    assert m.bad_1 == pytest.approx(100 * 5 / 7)
    assert m.bad_2 == pytest.approx(100 * 4 / 7)
    assert m.bad_4 == pytest.approx(100 * 2 / 7)
    # D1: err > 3 and > 5 % gt: 3.5 (> 0.5) yes; 10 (gt 100 -> 5) yes; invalid yes
    assert m.d1 == pytest.approx(100 * 3 / 7)
    assert m.invalid == pytest.approx(100 / 7)
    assert m.rms == pytest.approx(math.sqrt((errors**2).sum() / 6))
    assert m.avgerr == pytest.approx(errors.sum() / 6)
    assert pobmp(est, gt) == m.pobmp and rms(est, gt) == m.rms
    assert pobmp(est, gt, delta=1.0) == m.bad_1


def test_d1_relative_threshold_excludes_large_gt():
    gt = np.array([[100.0, 10.0]])
    est = np.array([[104.0, 14.0]])  # error 4 > 3 px both; 4 > 5 % only for gt 10
    assert evaluate(est, gt).d1 == 50.0


def test_threshold_is_strict():
    gt = np.zeros((1, 2)) + 1
    assert pobmp(np.array([[4.0, 1.0]]), gt) == 0.0  # |4 - 1| = 3, not > 3
    assert pobmp(np.array([[4.0, 1.0]]), gt, delta=2.9) == 50.0


def test_all_invalid_estimates():
    gt = np.ones((2, 2))
    m = evaluate(np.full((2, 2), INF), gt)
    assert m.pobmp == m.bad_0_5 == m.d1 == m.invalid == 100.0
    assert math.isnan(m.rms) and math.isnan(m.avgerr)
    assert math.isnan(rms(np.full((2, 2), NAN), gt))


def test_negative_inf_estimate_is_invalid_and_integer_estimates_accepted():
    gt = np.array([[2.0, 2.0]])
    assert evaluate(np.array([[-INF, 2.0]]), gt).invalid == 50.0
    assert evaluate(np.array([[2, 9]], np.int32), gt).pobmp == 50.0


def test_nan_gt_is_no_ground_truth():
    gt = np.array([[NAN, 1.0]], np.float32)
    assert evaluate(np.array([[100.0, 1.0]]), gt).n_pixels == 1


def test_mask_and_regions():
    gt = np.array([[1.0, 1.0, 1.0, 1.0]])
    est = np.array([[1.0, 9.0, 9.0, 9.0]])
    occ = np.array([[255, 128, 255, 0]], np.uint8)
    m_all = evaluate(est, gt, occlusion_mask=occ)  # code 0 excluded even in "all"
    assert (m_all.n_pixels, m_all.pobmp) == (3, pytest.approx(200 / 3))
    m_noc = evaluate(est, gt, region="nonocc", occlusion_mask=occ)
    assert (m_noc.n_pixels, m_noc.pobmp, m_noc.region) == (2, 50.0, "nonocc")
    keep = np.array([[True, False, False, True]])
    assert evaluate(est, gt, mask=keep).pobmp == 50.0
    assert evaluate(est, gt, mask=keep, region="nonocc", occlusion_mask=occ).n_pixels == 1
    assert evaluate(est, gt).n_pixels == 4


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"disparity": np.zeros((2, 3))}, ValueError, r"disparity: expected shape \(2, 2\)"),
        ({"gt": np.ones((2, 2), np.uint8)}, TypeError, "gt: expected a float32 or float64"),
        ({"disparity": np.zeros((2, 2), bool)}, TypeError, "disparity: expected a float or integer"),
        ({"disparity": [[1.0, 1.0]]}, TypeError, "numpy array"),
        ({"gt": np.ones((2, 2, 1))}, ValueError, "2-D"),
        ({"delta": 0}, ValueError, "delta"),
        ({"delta": -1.0}, ValueError, "delta"),
        ({"delta": float("nan")}, ValueError, "delta"),
        ({"delta": True}, TypeError, "delta"),
        ({"region": "occ"}, ValueError, "region"),
        ({"region": "nonocc"}, ValueError, "occlusion_mask: region='nonocc' needs"),
        ({"mask": np.ones((2, 2), np.uint8)}, TypeError, "mask: expected a bool"),
        ({"mask": np.ones((3, 2), bool)}, ValueError, "mask: expected shape"),
        ({"occlusion_mask": np.full((2, 2), 255.0)}, TypeError, "occlusion_mask: expected a uint8"),
        ({"occlusion_mask": np.full((2, 2), 254, np.uint8)}, ValueError, r"codes .*\[254\]"),
        ({"occlusion_mask": np.full((2, 3), 255, np.uint8)}, ValueError, "occlusion_mask: expected shape"),
        ({"gt": np.full((2, 2), INF)}, ValueError, "no pixel to evaluate"),
        ({"mask": np.zeros((2, 2), bool)}, ValueError, "no pixel to evaluate"),
        ({"occlusion_mask": np.full((2, 2), 128, np.uint8), "region": "nonocc"}, ValueError, "no pixel"),
    ],
)
def test_validation(kwargs, error, message):
    args = {"disparity": np.zeros((2, 2)), "gt": np.ones((2, 2))} | kwargs
    disparity, gt = args.pop("disparity"), args.pop("gt")
    with pytest.raises(error, match=message):
        evaluate(disparity, gt, **args)
