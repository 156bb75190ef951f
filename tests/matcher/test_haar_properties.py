"""Properties of matcher.haar: perfect reconstruction, energy, constants."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matcher.haar import haar2d, ihaar2d
from matcher.testing import grey_images

norms = st.sampled_from(["orthonormal", "average"])


@given(grey_images(min_side=1, max_side=33), norms)
def test_perfect_reconstruction(img, norm):
    np.testing.assert_allclose(ihaar2d(haar2d(img, norm=norm)), img, rtol=0, atol=1e-9)


def test_perfect_reconstruction_example():
    img = np.array([[1, 2, 3], [4, 5, 6], [7, 8, 9]], np.uint8)
    np.testing.assert_allclose(ihaar2d(haar2d(img, norm="average")), img, rtol=0, atol=1e-12)


@given(st.integers(1, 20), st.integers(1, 20), st.floats(-1e3, 1e3), norms)
def test_constant_image_has_constant_ll_and_no_detail(h, w, value, norm):
    b = haar2d(np.full((h, w), value), norm=norm)
    scale = 2.0 if norm == "orthonormal" else 1.0
    np.testing.assert_allclose(b.ll, scale * value, rtol=1e-12, atol=1e-9)
    for band in (b.lh, b.hl, b.hh):
        np.testing.assert_allclose(band, 0.0, atol=1e-9)


def test_constant_image_example():
    b = haar2d(np.full((3, 4), 7, np.uint8), norm="average")
    assert np.all(b.ll == 7.0)


@given(grey_images(min_side=2, max_side=32).filter(lambda a: a.shape[0] % 2 == 0 and a.shape[1] % 2 == 0))
def test_orthonormal_preserves_energy_on_even_sizes(img):
    b = haar2d(img)
    x = img.astype(np.float64)
    energy = sum(float((band**2).sum()) for band in (b.ll, b.lh, b.hl, b.hh))
    np.testing.assert_allclose(energy, float((x**2).sum()), rtol=1e-12)


def test_energy_example():
    b = haar2d(np.array([[1.0, 0.0], [0.0, 0.0]]))
    assert [float(v[0, 0]) for v in (b.ll, b.lh, b.hl, b.hh)] == [0.5, 0.5, 0.5, 0.5]
