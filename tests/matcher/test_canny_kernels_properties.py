"""Property: the numba Canny stage equals cv2.Canny(dx, dy, L2gradient=True) bit for bit."""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matcher._kernels import canny_on_derivatives


def opencv_canny(dx, dy, low, high):
    return cv2.Canny(dx, dy, low, high, L2gradient=True) > 0


@st.composite
def derivative_fields(draw):
    """int16 derivatives: Sobel of a smoothed random image (edges, ridges, plateaus), or raw
    random values (every direction and magnitude, saturation included)."""
    h = draw(st.integers(1, 48))
    w = draw(st.integers(1, 48))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if draw(st.booleans()):
        img = rng.random((h, w)).astype(np.float32) * 255
        sigma = draw(st.sampled_from([0.5, 1.0, 2.0]))
        img = cv2.GaussianBlur(img, (0, 0), sigma, borderType=cv2.BORDER_REPLICATE)
        dx = cv2.Sobel(img, cv2.CV_16S, 1, 0, ksize=3, scale=8.0, borderType=cv2.BORDER_REPLICATE)
        dy = cv2.Sobel(img, cv2.CV_16S, 0, 1, ksize=3, scale=8.0, borderType=cv2.BORDER_REPLICATE)
        scale = 2000.0
    else:
        top = draw(st.sampled_from([3, 300, 32768]))
        dx = rng.integers(-top, top, (h, w)).astype(np.int16)
        dy = rng.integers(-top, top, (h, w)).astype(np.int16)
        scale = 1.5 * top
    low = draw(st.floats(0, 1)) * scale
    high = low + draw(st.floats(0, 1)) * scale
    return dx, dy, low, high


@given(derivative_fields(), st.integers(1, 9))
def test_equals_opencv(field, strip):
    dx, dy, low, high = field
    got = canny_on_derivatives(dx, dy, low, high, strip=strip)
    assert np.array_equal(got, opencv_canny(dx, dy, low, high))


def test_equals_opencv_example():
    rng = np.random.default_rng(0)
    img = cv2.GaussianBlur(rng.random((32, 40)).astype(np.float32) * 255, (0, 0), 1.0)
    dx = cv2.Sobel(img, cv2.CV_16S, 1, 0, ksize=3, scale=8.0)
    dy = cv2.Sobel(img, cv2.CV_16S, 0, 1, ksize=3, scale=8.0)
    got = canny_on_derivatives(dx, dy, 300.0, 600.0, strip=5)
    assert got.any() and not got.all()
    assert np.array_equal(got, opencv_canny(dx, dy, 300.0, 600.0))
