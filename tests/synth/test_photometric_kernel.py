"""The fused noise pass and the JPEG round trip of ``apply_photometric`` against the OpenCV
pipelines they replaced.

Before the fused pass a noisy image was ``cv2.addWeighted(x, gain, gaussian_noise(...), 1, bias,
dtype=CV_8U)`` with ``x`` the image (uint8), its gamma table lookup (``cv2.LUT``, float32) or its
blurred and gamma-corrected float32 values; the pass must give the same bytes from the same rng.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from synth.appearance.photometric import (
    PhotometricParams,
    _gamma,
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
            if gamma != 1.0:
                xs = [_gamma(v, gamma) for v in xs]
            noise = [gaussian_noise(img.shape, 2.5, rng=rng) for _ in range(2)]
            expected = [cv2.addWeighted(xs[0], 1.0, noise[0], 1.0, 0.0, dtype=cv2.CV_8U),
                        cv2.addWeighted(xs[1], 1.07, noise[1], 1.0, -3.5, dtype=cv2.CV_8U)]
            np.testing.assert_array_equal(out.left, expected[0])
            np.testing.assert_array_equal(out.right, expected[1])


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
