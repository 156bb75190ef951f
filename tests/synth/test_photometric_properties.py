"""Properties of the photometric models on random images."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from synth.appearance.photometric import (
    PhotometricParams,
    _normal_quantiles,
    apply_photometric,
    gaussian_noise,
)

images = arrays(np.uint8, st.tuples(st.integers(2, 24), st.integers(2, 24), st.just(3)))
params = st.builds(
    PhotometricParams,
    noise_sigma=st.floats(0.0, 10.0),
    gain=st.floats(0.5, 2.0),
    bias=st.floats(-20.0, 20.0),
    gamma=st.floats(0.5, 2.0),
    blur_sigma=st.floats(0.0, 2.0),
    jpeg_quality=st.sampled_from([0, 60, 95]),
)


@given(images, params, st.integers(0, 2**32))
def test_output_is_uint8_of_the_input_shape_and_seed_determined(img, p, seed):
    a = apply_photometric(img, img[::-1].copy(), p, rng=seed)
    b = apply_photometric(img, img[::-1].copy(), p, rng=seed)
    for x, y in zip(a, b):
        assert x.dtype == np.uint8 and x.shape == img.shape
        np.testing.assert_array_equal(x, y)


def test_output_example():
    img = np.full((3, 5, 3), 9, np.uint8)
    out = apply_photometric(img, img, PhotometricParams(noise_sigma=1.0, jpeg_quality=60), rng=0)
    assert out.left.shape == (3, 5, 3) and out.right.dtype == np.uint8


@given(images, st.floats(0.5, 2.0), st.floats(-20.0, 20.0))
def test_gain_bias_never_touch_the_left_image_and_are_affine_on_the_right(img, gain, bias):
    out = apply_photometric(img, img, PhotometricParams(gain=gain, bias=bias), rng=0)
    np.testing.assert_array_equal(out.left, img)
    expected = np.clip(np.rint(img.astype(np.float32) * np.float32(gain) + np.float32(bias)),
                       0, 255)
    np.testing.assert_array_equal(out.right, expected.astype(np.uint8))


def test_gain_bias_example():
    img = np.array([[[0, 100, 250]]], np.uint8)
    out = apply_photometric(img, img, PhotometricParams(gain=1.5, bias=-10.0), rng=0)
    assert out.right.tolist() == [[[0, 140, 255]]]


@given(st.floats(0.01, 64.0), st.integers(0, 2**32), st.integers(1, 300))
def test_gaussian_noise_scales_linearly_with_sigma(sigma, seed, n):
    unit = gaussian_noise((n,), 1.0, rng=seed).astype(np.float64)
    scaled = gaussian_noise((n,), sigma, rng=seed).astype(np.float64)
    np.testing.assert_allclose(scaled, sigma * unit, rtol=1e-6, atol=0)


def test_gaussian_noise_scales_linearly_example():
    np.testing.assert_allclose(gaussian_noise((4,), 8.0, rng=1),
                               8.0 * gaussian_noise((4,), 1.0, rng=1), rtol=1e-6)


@given(st.floats(0.5, 32.0), st.integers(0, 2**32))
def test_gaussian_noise_has_the_requested_sigma(sigma, seed):
    x = gaussian_noise((64, 64), sigma, rng=seed).astype(np.float64)
    assert abs(x.std() / sigma - 1.0) < 0.05  # ~4.5 standard errors for 4096 values
    assert abs(x.mean()) < 0.07 * sigma


def test_gaussian_noise_sigma_example():
    x = gaussian_noise((64, 64), 3.0, rng=0).astype(np.float64)
    assert 2.85 < x.std() < 3.15


@given(st.lists(st.integers(1, 9), min_size=1, max_size=3), st.floats(0.0, 64.0),
       st.integers(0, 2**32))
def test_gaussian_noise_equals_the_table_lookup(shape, sigma, seed):
    # hand-picked companion: test_gaussian_noise_is_the_table_lookup_of_its_16_bit_words
    shape = tuple(shape)
    size = int(np.prod(shape))
    words = np.random.default_rng(seed).bit_generator.random_raw((size + 3) // 4)
    index = words.astype("<u8").view("<u2")[:size]
    expected = (_normal_quantiles() * sigma).astype(np.float32).take(index).reshape(shape)
    np.testing.assert_array_equal(gaussian_noise(shape, sigma, rng=seed), expected)
