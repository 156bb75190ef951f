"""matcher._kernels.canny: the numba port of cv2.Canny's last stage, checked bit for bit."""

from __future__ import annotations

import cv2
import numpy as np

from matcher._kernels import canny_on_derivatives, canny_thresholds


def opencv_canny(dx, dy, low, high):
    return cv2.Canny(dx, dy, low, high, L2gradient=True) > 0


def test_thresholds_are_floored_squares_clamped_and_ordered():
    assert canny_thresholds(204.0, 408.0) == (204 * 204, 408 * 408)
    assert canny_thresholds(1.5, 2.5) == (2, 6)  # floor(2.25), floor(6.25)
    assert canny_thresholds(40000.0, 50000.0) == (32767 * 32767, 32767 * 32767)
    assert canny_thresholds(9.0, 3.0) == (9, 81)  # swapped, as OpenCV does
    assert canny_thresholds(0.0, 0.0) == (0, 0)


def test_vertical_step_edge_hand_example():
    img = np.zeros((12, 12), np.uint8)
    img[:, 6:] = 200
    dx = cv2.Sobel(img, cv2.CV_16S, 1, 0, ksize=3, borderType=cv2.BORDER_REPLICATE)
    dy = cv2.Sobel(img, cv2.CV_16S, 0, 1, ksize=3, borderType=cv2.BORDER_REPLICATE)
    got = canny_on_derivatives(dx, dy, 100.0, 200.0)
    assert np.array_equal(got, opencv_canny(dx, dy, 100.0, 200.0))
    assert got[:, 5].all() and got.sum() == 12  # one column, the left side of the step


def test_weak_chain_across_many_strips_is_joined():
    # a vertical weak ridge (above low, below high) with one strong pixel at its bottom:
    # hysteresis must walk it up through every one-row strip
    dx = np.zeros((20, 9), np.int16)
    dx[:, 4] = 50
    dx[19, 4] = 300
    dy = np.zeros_like(dx)
    for strip in (1, 2, 3, 7, 20):
        got = canny_on_derivatives(dx, dy, 40.0, 100.0, strip=strip)
        assert np.array_equal(got, opencv_canny(dx, dy, 40.0, 100.0))
        assert got[:, 4].all() and got.sum() == 20


def test_saturated_derivatives_follow_opencv_int_arithmetic():
    rng = np.random.default_rng(3)
    dx = rng.choice(np.array([-32768, -32767, 0, 32767], np.int16), (16, 16))
    dy = rng.choice(np.array([-32768, 1, 32767], np.int16), (16, 16))
    for low, high in ((0.0, 0.0), (1000.0, 30000.0), (40000.0, 40000.0)):
        got = canny_on_derivatives(dx, dy, low, high)
        assert np.array_equal(got, opencv_canny(dx, dy, low, high))


def test_tiny_images():
    for shape in ((1, 1), (1, 5), (5, 1), (2, 2)):
        dx = np.full(shape, 500, np.int16)
        dy = np.zeros(shape, np.int16)
        got = canny_on_derivatives(dx, dy, 10.0, 20.0)
        assert np.array_equal(got, opencv_canny(dx, dy, 10.0, 20.0))
