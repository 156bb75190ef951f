"""Photometric models: each model on hand-picked images, determinism, validation."""

from __future__ import annotations

import numpy as np
import pytest

from synth.photometric import PhotometricParams, apply_photometric


def _flat(value: int, shape=(16, 16, 3)) -> np.ndarray:
    return np.full(shape, value, np.uint8)


def test_identity_returns_the_inputs():
    left, right = _flat(10), _flat(20)
    out = apply_photometric(left, right, PhotometricParams(), rng=0)
    assert out.left is left and out.right is right


def test_gain_and_bias_act_on_the_right_image_only():
    out = apply_photometric(_flat(100), _flat(100), PhotometricParams(gain=0.5, bias=10.0), rng=0)
    assert (out.left == 100).all() and (out.right == 60).all()


def test_gain_and_bias_clip_to_uint8():
    out = apply_photometric(_flat(200), _flat(200), PhotometricParams(gain=2.0, bias=-128.0),
                            rng=0)
    assert (out.right == 255).all()


def test_gamma_matches_the_formula():
    img = np.arange(256, dtype=np.uint8).reshape(16, 16)
    out = apply_photometric(img, img, PhotometricParams(gamma=2.0), rng=0)
    expected = np.rint(255.0 * (np.arange(256) / 255.0) ** 2).astype(np.uint8).reshape(16, 16)
    np.testing.assert_array_equal(out.left, expected)
    np.testing.assert_array_equal(out.right, expected)


def test_blur_keeps_a_constant_image_and_smooths_a_step():
    out = apply_photometric(_flat(77), _flat(77), PhotometricParams(blur_sigma=2.0), rng=0)
    assert (out.left == 77).all()
    step = np.zeros((8, 16), np.uint8)
    step[:, 8:] = 200
    blurred = apply_photometric(step, step, PhotometricParams(blur_sigma=1.0), rng=0).left
    assert 0 < blurred[4, 7] < 100 < blurred[4, 8] < 200
    assert blurred[4, 0] == 0 and blurred[4, 15] == 200


def test_noise_has_the_requested_sigma_and_is_independent_per_image():
    params = PhotometricParams(noise_sigma=8.0)
    out = apply_photometric(_flat(128, (64, 64)), _flat(128, (64, 64)), params, rng=3)
    for img in out:
        residual = img.astype(np.float64) - 128.0
        assert abs(residual.mean()) < 0.5
        assert 7.5 < residual.std() < 8.5
    assert (out.left != out.right).mean() > 0.9


def test_noise_is_deterministic_in_the_seed():
    params = PhotometricParams(noise_sigma=3.0, jpeg_quality=80)
    a = apply_photometric(_flat(50), _flat(90), params, rng=7)
    b = apply_photometric(_flat(50), _flat(90), params, rng=np.random.default_rng(7))
    c = apply_photometric(_flat(50), _flat(90), params, rng=8)
    np.testing.assert_array_equal(a.left, b.left)
    np.testing.assert_array_equal(a.right, b.right)
    assert not np.array_equal(a.left, c.left)


def test_jpeg_round_trip_is_lossy_but_close():
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (32, 32, 3), dtype=np.uint8)
    out = apply_photometric(img, img, PhotometricParams(jpeg_quality=50), rng=0)
    assert out.left.shape == img.shape and out.left.dtype == np.uint8
    assert not np.array_equal(out.left, img)
    smooth = np.tile(np.linspace(0, 255, 32).astype(np.uint8), (32, 1))
    back = apply_photometric(smooth, smooth, PhotometricParams(jpeg_quality=95), rng=0).left
    assert np.abs(back.astype(int) - smooth).max() <= 4


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gain": 0.0}, r"gain must be in \(0, 4\]"),
        ({"noise_sigma": -1.0}, r"noise_sigma must be in \[0, 64\]"),
        ({"gamma": float("nan")}, "gamma"),
        ({"jpeg_quality": 101}, r"jpeg_quality must be an int in \[0, 100\]"),
        ({"jpeg_quality": 50.0}, "jpeg_quality"),
    ],
)
def test_params_are_validated(kwargs, match):
    with pytest.raises(ValueError, match=match):
        PhotometricParams(**kwargs)


def test_inputs_are_validated():
    with pytest.raises(TypeError, match="uint8"):
        apply_photometric(np.zeros((4, 4)), _flat(0, (4, 4)), PhotometricParams(), rng=0)
    with pytest.raises(ValueError, match="one shape"):
        apply_photometric(_flat(0, (4, 4)), _flat(0, (4, 5)), PhotometricParams(), rng=0)
    with pytest.raises(ValueError, match="unknown photometric"):
        PhotometricParams.from_mapping({"gian": 1.0})
