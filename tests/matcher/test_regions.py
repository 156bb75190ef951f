"""Validation regions from exact ground truth, and region-wise scores (hand-picked cases)."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.regions import (
    DISCONTINUITY_RADIUS,
    TEXTURELESS_ENERGY,
    gradient_energy,
    occlusion_from_disparities,
    region_masks,
    region_scores,
)


def test_regions_of_a_step_with_an_occluded_band_and_a_flat_half():
    h, w = 20, 30
    gt = np.full((h, w), 4.0, np.float32)
    gt[:, 15:] = 9.0  # a depth edge between x = 14 and 15
    gt[0, :] = np.inf  # no ground truth on the top row
    occ = np.full((h, w), 255, np.uint8)
    occ[:, 15:18] = 128
    occ[0, :] = 0
    image = np.zeros((h, w, 3), np.uint8)
    rng = np.random.default_rng(0)
    image[:, :15] = rng.integers(0, 256, (h, 15, 3))  # textured left half, flat right half
    m = region_masks(gt, occ, image)
    assert m["all"].sum() == (h - 1) * w and not m["all"][0].any()
    assert m["occluded"].sum() == (h - 1) * 3 and (m["nonocc"] | m["occluded"] == m["all"]).all()
    # discontinuity: within 3 px of the edge pixels (x = 14 and 15), and along the missing row
    row = m["discontinuity"][10]
    assert row.nonzero()[0].tolist() == list(range(14 - DISCONTINUITY_RADIUS, 16 + DISCONTINUITY_RADIUS))
    assert m["discontinuity"][1:1 + DISCONTINUITY_RADIUS].all()
    # textureless: the flat half away from the texture (the 7x7 energy box reaches 3 px over)
    assert m["textureless"][5:, 19:].all() and not m["textureless"][5:, :14].any()


def test_textureless_threshold_is_the_documented_energy():
    ramp = np.tile(np.arange(40, dtype=np.float64), (20, 1))  # gradient 1 grey level / px
    energy = gradient_energy(ramp)
    assert np.allclose(energy[5:-5, 5:-5], 1.0)
    steep = ramp * 2.5  # RMS gradient 2.5 > 2: energy 6.25 above the threshold of 4
    gt, occ = np.ones((20, 40)), np.full((20, 40), 255, np.uint8)
    assert region_masks(gt, occ, ramp)["textureless"][5:-5, 5:-5].all()
    assert not region_masks(gt, occ, steep)["textureless"][5:-5, 5:-5].any()
    assert TEXTURELESS_ENERGY == 4.0


def test_scores_count_missing_estimates_as_bad_and_errors_over_estimated_pixels():
    gt = np.array([[1.0, 1.0, 1.0, 1.0]])
    est = np.array([[1.2, 2.5, np.nan, 9.0]])
    s = region_scores(est, gt, np.ones((1, 4), bool))
    assert s["coverage"] == 0.75
    assert s["bad_0_5"] == 0.75 and s["bad_1"] == 0.75 and s["bad_2"] == 0.5 and s["bad_4"] == 0.5
    assert s["avgerr"] == pytest.approx((0.2 + 1.5 + 8.0) / 3)
    failed = region_scores(None, gt, np.ones((1, 4), bool))
    assert failed["bad_0_5"] == 1.0 and failed["coverage"] == 0.0 and failed["avgerr"] is None
    assert all(v is None for v in region_scores(est, gt, np.zeros((1, 4), bool)).values())


def test_an_error_equal_to_the_threshold_is_good_as_in_middlebury():
    # errors of exactly 0.5, 1, 2 and 4 (all exact in binary): Middlebury's bad-x is |err| > x
    gt = np.ones((1, 4))
    est = np.array([[1.5, 2.0, 3.0, 5.0]])
    s = region_scores(est, gt, np.ones((1, 4), bool))
    assert (s["bad_0_5"], s["bad_1"], s["bad_2"], s["bad_4"]) == (0.75, 0.5, 0.25, 0.0)
    # a hair above the threshold is bad
    above = region_scores(np.array([[2.0 + 1e-9]]), np.ones((1, 1)), np.ones((1, 1), bool))
    assert above["bad_1"] == 1.0 and above["bad_2"] == 0.0


def test_a50_a90_a99_are_quantiles_of_the_absolute_error():
    # errors 0, 1, ..., 100 over the estimated pixels (one missing pixel is left out of them)
    err = np.arange(101, dtype=np.float64)
    gt = np.zeros((1, 102))
    est = np.concatenate([-err[::2], err[1::2], [np.inf]])[None]
    s = region_scores(est, gt, np.ones((1, 102), bool))
    assert (s["a50"], s["a90"], s["a99"]) == (50.0, 90.0, 99.0)
    assert s["avgerr"] == 50.0


def test_occlusion_from_two_ground_truths_is_a_left_right_check():
    # a fronto-parallel object (d = 6) in front of a background (d = 2), 4 px wide
    w = 24
    left = np.full((3, w), 2.0)
    left[:, 10:14] = 6.0
    right = np.full((3, w), 2.0)  # the right view sees the object 6 px to the left
    right[:, 4:8] = 6.0
    left[2, 20] = np.inf  # unknown
    occ = occlusion_from_disparities(left, right)
    row = occ[0].tolist()
    # x = 0, 1 match outside the right view; the background at x = 6..9 is hidden by the
    # object there (its match x - 2 = 4..7 sees d = 6)
    assert row[:2] == [128, 128] and row[6:10] == [128] * 4
    assert row[2:6] == [255] * 4 and row[10:] == [255] * (w - 10)
    assert occ[2, 20] == 0
    # with the right view made from the left ground truth, the same answer
    assert (occlusion_from_disparities(left) == occ).all()
    # a right ground truth that disagrees by more than the tolerance: not confirmed visible
    assert (occlusion_from_disparities(left, right + 1.5)[0] == 128).all()
    assert occlusion_from_disparities(left, right + 1.0, tolerance=1.0)[0, 12] == 255
