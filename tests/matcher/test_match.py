"""The match API: exact disparities on constructed pairs, fused == reference, ops, errors."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import matcher
from matcher import match
from synth.jobs.bench.match import textured_pair
from matcher.census import census_transform
from matcher.cost import aggregate_cost, cost_volume
from matcher.select import winner_takes_all


@pytest.fixture(scope="module")
def pair():
    """40 x 28 noise-free pair cut from one random texture: true disparity 5 (x >= 5)."""
    strip = np.random.default_rng(11).integers(0, 256, (28, 45)).astype(np.uint8)
    return strip[:, :40].copy(), strip[:, 5:45].copy()


def reference(left, right, *, method, window, max_disparity, aggregate, lr_check, subpixel):
    pattern = "dense" if method == "ct" else "sparse"
    cl = census_transform(left, window=window, pattern=pattern)
    cr = census_transform(right, window=window, pattern=pattern)
    cost = cost_volume(cl, cr, max_disparity=max_disparity)
    if aggregate is not None:
        cost = aggregate_cost(cost, size=aggregate)
    return winner_takes_all(cost, lr_check=lr_check, subpixel=subpixel)


def test_identical_views_give_zero():
    img = np.random.default_rng(0).integers(0, 255, (20, 30)).astype(np.uint8)
    res = match(img, img, window=5, max_disparity=8)
    assert res.disparity.dtype == np.float32 and res.disparity.shape == (20, 30)
    assert not res.disparity.any()


@pytest.mark.parametrize("method", ["ct", "sct"])
def test_known_shift_is_found_in_the_interior(pair, method):
    left, right = pair
    res = match(left, right, method=method, window=7, max_disparity=12)
    interior = res.disparity[3:-3, 5 + 3 : -3]
    assert (interior == 5.0).mean() > 0.9
    # Every miss is an exact tie won by a smaller d (e.g. a local extremum whose code is all 0 or 1)
    pattern = "dense" if method == "ct" else "sparse"
    cost = cost_volume(census_transform(left, window=7, pattern=pattern),
                       census_transform(right, window=7, pattern=pattern), max_disparity=12)
    cost = cost[3:-3, :, 5 + 3 : -3]
    assert not cost[:, 5].any()  # the true shift costs 0 everywhere in the interior
    ys, xs = np.nonzero(interior != 5.0)
    chosen = interior[ys, xs].astype(int)
    assert (chosen < 5).all() and not cost[ys, chosen, xs].any()


@pytest.mark.parametrize("method", ["ct", "sct"])
@pytest.mark.parametrize("aggregate", [None, 3, 5])
@pytest.mark.parametrize(("lr_check", "subpixel"), [(False, False), (True, False), (True, True)])
def test_fused_equals_cost_volume_path(pair, method, aggregate, lr_check, subpixel):
    left, right = pair
    kwargs = dict(method=method, window=5, max_disparity=9, aggregate=aggregate,
                  lr_check=lr_check, subpixel=subpixel)
    np.testing.assert_array_equal(match(left, right, **kwargs).disparity,
                                  reference(left, right, **kwargs))


def test_fused_with_many_ties_equals_cost_volume_path():
    rng = np.random.default_rng(2)
    left = rng.integers(0, 3, (26, 33)).astype(np.uint8)
    right = rng.integers(0, 3, (26, 33)).astype(np.uint8)
    kwargs = dict(method="ct", window=3, max_disparity=20, aggregate=None, lr_check=True,
                  subpixel=True)
    np.testing.assert_array_equal(match(left, right, **kwargs).disparity,
                                  reference(left, right, **kwargs))


def test_lr_check_marks_the_occluded_band():
    rng = np.random.default_rng(4)
    h, w, a, b, y0, y1 = 40, 64, 30, 50, 8, 32
    bg = rng.integers(0, 256, (h, w + 2)).astype(np.uint8)
    fg = rng.integers(0, 256, (h, w)).astype(np.uint8)
    left = bg[:, :w].copy()
    left[y0:y1, a:b] = fg[y0:y1, a:b]  # foreground at disparity 8, background at 2
    right = bg[:, 2 : w + 2].copy()
    right[y0:y1, a - 8 : b - 8] = fg[y0:y1, a:b]
    res = match(left, right, window=5, max_disparity=12, lr_check=True)
    occluded = res.disparity[y0 + 2 : y1 - 2, a - 6 : a - 1]  # background hidden in the right view
    visible_fg = res.disparity[y0 + 2 : y1 - 2, a + 2 : b - 2]
    assert np.isinf(occluded).mean() > 0.6
    assert (visible_fg == 8.0).mean() > 0.9  # misses: census ties at local extrema
    plain = match(left, right, window=5, max_disparity=12).disparity
    assert np.isfinite(plain).all()


def test_op_counts_hand_example():
    img = np.random.default_rng(1).integers(0, 255, (4, 6)).astype(np.uint8)
    res = match(img, img, window=3, max_disparity=3)
    # census: 2 images x 24 pixels x 8 bits; Hamming: 4 rows x 1 word x (6 + 5 + 4) candidates
    assert res.ops == matcher.OpCounts(census_comparisons=384, hamming_words=60)
    sparse = match(img, img, method="sct", window=3, max_disparity=3)
    assert sparse.ops == matcher.OpCounts(census_comparisons=2 * 24 * 4, hamming_words=60)
    big = np.zeros((30, 30), np.uint8)
    assert match(big, big, window=21, max_disparity=2).ops.hamming_words == 30 * 7 * (30 + 29)


def test_result_fields(pair):
    left, right = pair
    res = match(left, right, method="sct", window=5, max_disparity=9, aggregate=3)
    assert (res.method, res.window, res.max_disparity) == ("sct", 5, 9)
    assert res.params["aggregate"] == 3 and res.params["n_bits"] == 4
    with pytest.raises(TypeError):
        res.params["aggregate"] = 5  # read-only


def test_rgb_and_float_inputs_agree_with_grey(pair):
    left, right = pair
    ref = match(left, right, window=5, max_disparity=9).disparity
    rgb = match(np.repeat(left[..., None], 3, axis=2), np.repeat(right[..., None], 3, axis=2),
                window=5, max_disparity=9).disparity
    flt = match(left / 255.0, right / 255.0, window=5, max_disparity=9).disparity
    np.testing.assert_array_equal(rgb, ref)
    np.testing.assert_array_equal(flt, ref)


@pytest.mark.parametrize("method", ["bm", "sgbm"])
def test_opencv_baselines_recover_the_shift(method):
    left, right = textured_pair(96, 64, shift=6, rng=3)
    res = match(left, right, method=method, window=9, max_disparity=20, subpixel=True)
    assert res.ops is None and res.params["numDisparities"] == 32
    finite = res.disparity[np.isfinite(res.disparity)]
    assert finite.size > 0.5 * res.disparity.size and finite.min() >= 0
    assert np.median(res.disparity[10:-10, 40:-10]) == pytest.approx(6.0, abs=0.25)
    rounded = match(left, right, method=method, window=9, max_disparity=20).disparity
    assert np.array_equal(rounded[np.isfinite(rounded)], np.round(rounded[np.isfinite(rounded)]))


def test_sgbm_parameters():
    img = np.zeros((32, 48), np.uint8)
    res = match(img, img, method="sgbm", window=5, max_disparity=17)
    assert (res.params["P1"], res.params["P2"], res.params["numDisparities"]) == (200, 800, 32)


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"window": 4}, ValueError, "window: expected an odd"),
        ({"window": 1}, ValueError, "window: expected an odd"),
        ({"window": 21}, ValueError, "window: expected at most"),
        ({"max_disparity": 24}, ValueError, "max_disparity"),
        ({"max_disparity": 0}, ValueError, "max_disparity"),
        ({"method": "sad"}, ValueError, "method"),
        ({"aggregate": 4}, ValueError, "aggregate"),
        ({"method": "bm", "aggregate": 3}, ValueError, "aggregate"),
        ({"method": "bm", "window": 3}, ValueError, "window: expected an odd integer >= 5"),
        ({"lr_check": 1}, TypeError, "lr_check"),
        ({"lr_tolerance": -1}, ValueError, "lr_tolerance"),
    ],
)
def test_bad_arguments(kwargs, error, message):
    img = np.zeros((16, 24), np.uint8)
    with pytest.raises(error, match=message):
        match(img, img, **{"window": 3, "max_disparity": 4, **kwargs})


def test_bad_images():
    img = np.zeros((16, 24), np.uint8)
    with pytest.raises(ValueError, match="same shape"):
        match(img, img[:, :-1], window=3, max_disparity=4)
    nan = np.zeros((16, 24))
    nan[3, 3] = np.nan
    with pytest.raises(ValueError, match="right: expected finite"):
        match(img, nan, window=3, max_disparity=4)


def test_package_root_exports_and_dependency_direction():
    assert matcher.match is match and "match" in matcher.__all__
    code = (
        "import sys, matcher; bad = [m for m in ('synth', 'scenes', 'pyrender', 'OpenGL', "
        "'matplotlib', 'psutil') if m in sys.modules]; print(bad)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
