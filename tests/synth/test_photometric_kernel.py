"""The fused noise pass and the JPEG round trip of ``apply_photometric`` against the OpenCV
pipelines they replaced.

Before the fused pass a noisy image was ``cv2.addWeighted(x, gain, gaussian_noise(...), 1, bias,
dtype=CV_8U)`` with ``x`` the image (uint8), its gamma table lookup (``cv2.LUT``, float32) or its
blurred (and gamma-corrected) float32 values; the pass must give the same bytes from the same rng.
A blurred image's gamma is that of its values rounded to 1/256 of a grey level, read from a
table: checked here against numpy's rounding and the exact power.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from synth.appearance.photometric import (
    PhotometricParams,
    _gamma,
    _gamma_table16,
    _grid16,
    _jpeg,
    _noisy_uint8,
    apply_photometric,
    gaussian_noise,
)


def _opencv(x: np.ndarray, gain: float, bias: float, sigma: float, seed: int) -> np.ndarray:
    noise = gaussian_noise(x.shape, sigma, rng=seed)
    return cv2.addWeighted(x, gain, noise, 1.0, bias, dtype=cv2.CV_8U)


@pytest.mark.parametrize("kind", ["uint8", "gamma table", "float32"])
def test_fused_pass_equals_opencv_add_weighted_of_the_noise(kind):
    rng = np.random.default_rng(7)
    for trial in range(40):
        shape = (540, 960, 3) if trial == 0 else (*(int(v) for v in rng.integers(1, 40, 2)), 3)
        image = rng.integers(0, 256, shape, dtype=np.uint8)
        gain, bias = float(rng.uniform(0.5, 1.5)), float(rng.uniform(-40, 40))
        sigma = float(rng.uniform(0.1, 20.0))
        if kind == "uint8":
            lut, x = np.arange(256, dtype=np.float32), image
        elif kind == "gamma table":
            lut = _gamma(np.arange(256, dtype=np.float32), float(rng.uniform(0.5, 2.0)))
            x = cv2.LUT(image, lut)
        else:  # blurred: any float32 values, some beyond 0..255
            lut = None
            x = image = (rng.random(shape, dtype=np.float32) * 300 - 20).astype(np.float32)
        got = _noisy_uint8(image, lut, gain, bias, sigma, np.random.default_rng(trial))
        np.testing.assert_array_equal(got, _opencv(x, gain, bias, sigma, trial))


def test_noisy_pairs_keep_their_bytes_under_every_combination_of_models():
    img = np.random.default_rng(1).integers(0, 256, (33, 47, 3), dtype=np.uint8)
    right = np.roll(img, 3, axis=1)
    for blur in (0.0, 1.0):
        for gamma in (1.0, 0.8):
            p = PhotometricParams(noise_sigma=2.5, gain=1.07, bias=-3.5, gamma=gamma,
                                  blur_sigma=blur)
            out = apply_photometric(img, right, p, rng=11)
            rng = np.random.default_rng(11)
            xs = [v.astype(np.float32) for v in (img, right)]
            if blur:
                k = 2 * int(np.ceil(3.0 * blur)) + 1
                xs = [cv2.GaussianBlur(v, (k, k), blur, sigmaY=blur,
                                       borderType=cv2.BORDER_REFLECT_101) for v in xs]
            if gamma != 1.0 and blur:  # the gamma of the values rounded to 1/256 grey level
                levels = np.arange(65281, dtype=np.float32) / np.float32(256)
                xs = [_gamma(levels, gamma)[_numpy_grid(v)] for v in xs]
            elif gamma != 1.0:
                xs = [_gamma(v, gamma) for v in xs]
            noise = [gaussian_noise(img.shape, 2.5, rng=rng) for _ in range(2)]
            expected = [cv2.addWeighted(xs[0], 1.0, noise[0], 1.0, 0.0, dtype=cv2.CV_8U),
                        cv2.addWeighted(xs[1], 1.07, noise[1], 1.0, -3.5, dtype=cv2.CV_8U)]
            np.testing.assert_array_equal(out.left, expected[0])
            np.testing.assert_array_equal(out.right, expected[1])


def _numpy_grid(x: np.ndarray) -> np.ndarray:
    """``round(256 x)``, halves up, clipped to 0..65280, in float64 (exact for float32 x)."""
    return np.clip(np.floor(x.astype(np.float64) * 256 + 0.5), 0, 65280).astype(np.int64)


def test_grid_rounds_to_the_nearest_256th_of_a_grey_level_halves_up():
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.random(100_000, dtype=np.float32) * 270 - 10,
                        (np.arange(-4, 65290) / 256).astype(np.float32),  # on the grid
                        ((np.arange(0, 65280) + 0.5) / 256).astype(np.float32),  # halves
                        np.float32([0, 1e-30, 255, 255.001, 1e6, -1e6])])
    got = _grid16(x)
    assert got.dtype == np.uint16
    np.testing.assert_array_equal(got, _numpy_grid(x))
    np.testing.assert_array_equal(_grid16(x.reshape(-1, 2)[:, ::-1]),  # strided
                                  _numpy_grid(x.reshape(-1, 2)[:, ::-1]))


def test_gamma_of_blurred_values_is_within_one_grey_level_of_the_exact_power():
    """The rounding moves a value by at most 1/512 grey level: after the noise and rounding to
    uint8 a few values are off by one, none by more."""
    rng = np.random.default_rng(5)
    img = cv2.GaussianBlur(rng.integers(0, 256, (270, 480, 3), dtype=np.uint8), (7, 7), 1.5)
    img = cv2.resize(img, (960, 540), interpolation=cv2.INTER_CUBIC)  # smooth, like renders
    changed = 0
    for gamma in (0.5, 0.8, 1.25, 2.2):
        p = PhotometricParams(noise_sigma=2.0, gamma=gamma, blur_sigma=1.0)
        got = apply_photometric(img, img, p, rng=4).left
        rng_ = np.random.default_rng(4)
        x = _gamma(cv2.GaussianBlur(img.astype(np.float32), (7, 7), 1.0, sigmaY=1.0,
                                    borderType=cv2.BORDER_REFLECT_101), gamma)
        exact = cv2.addWeighted(x, 1.0, gaussian_noise(img.shape, 2.0, rng=rng_), 1.0, 0.0,
                                dtype=cv2.CV_8U)
        diff = np.abs(got.astype(np.int16) - exact)
        assert diff.max() <= 1, gamma
        changed += np.count_nonzero(diff)
    assert 0 < changed < 0.01 * 4 * img.size


def test_gamma_table_is_the_gamma_of_the_grid_levels_and_read_only():
    table = _gamma_table16(0.8)
    levels = np.arange(65281, dtype=np.float32) / np.float32(256)
    np.testing.assert_array_equal(table, _gamma(levels, 0.8))
    assert table[0] == 0 and table[-1] == np.float32(255.0) and not table.flags.writeable
    assert _gamma_table16(0.8) is table  # cached: a sample's right-view variants share it


def test_blurred_gamma_without_noise_reads_the_same_table():
    img = np.random.default_rng(8).integers(0, 256, (30, 41, 3), dtype=np.uint8)
    p = PhotometricParams(gamma=1.7, blur_sigma=0.8, gain=1.1, bias=2.0)
    out = apply_photometric(img, img, p, rng=0)
    k = 2 * int(np.ceil(3.0 * 0.8)) + 1
    blurred = cv2.GaussianBlur(img.astype(np.float32), (k, k), 0.8, sigmaY=0.8,
                               borderType=cv2.BORDER_REFLECT_101)
    x = _gamma_table16(1.7)[_numpy_grid(blurred)]
    np.testing.assert_array_equal(out.left, np.clip(np.rint(x), 0, 255).astype(np.uint8))
    right = np.clip(np.rint(x * np.float32(1.1) + np.float32(2.0)), 0, 255).astype(np.uint8)
    np.testing.assert_array_equal(out.right, right)


@pytest.mark.parametrize("quality", [1, 75, 90, 95, 100])
def test_jpeg_round_trip_equals_opencv_of_the_reversed_channels(quality):
    """Channels swapped by cvtColor: the bytes of the former numpy channel reversal."""
    rng = np.random.default_rng(quality)
    for shape in ((37, 53, 3), (37, 53), (8, 9, 3)):
        img = cv2.GaussianBlur(rng.integers(0, 256, shape, dtype=np.uint8), (5, 5), 1.5)
        for view in (img, img[:, ::-1]):  # contiguous and strided
            colour = view.ndim == 3
            ok, buf = cv2.imencode(".jpg", view[..., ::-1] if colour else view,
                                   [cv2.IMWRITE_JPEG_QUALITY, quality])
            back = cv2.imdecode(buf, cv2.IMREAD_COLOR if colour else cv2.IMREAD_GRAYSCALE)
            expected = back[..., ::-1] if colour else back
            got = _jpeg(view, quality)
            assert got.flags.c_contiguous and got.dtype == np.uint8
            np.testing.assert_array_equal(got, expected)
