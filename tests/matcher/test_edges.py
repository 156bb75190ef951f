"""matcher.edges: Canny wrapper."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.edges import canny_edges


def _step(dtype=np.uint8, high=200):
    img = np.zeros((24, 24), dtype)
    img[:, 12:] = high
    return img


def test_step_edge_is_found_next_to_the_step_only():
    e = canny_edges(_step())
    assert e.dtype == np.bool_ and e.shape == (24, 24)
    assert e[3:21, 11:13].any(axis=1).all()
    assert not e[:, :9].any() and not e[:, 15:].any()


def test_flat_image_has_no_edges_and_border_is_not_an_edge():
    assert not canny_edges(np.full((20, 20), 90, np.uint8)).any()


def test_float_and_uint16_scaled_like_uint8():
    e8 = canny_edges(_step())
    ef = canny_edges(_step(np.float64, 200 / 255))
    e16 = canny_edges(_step(np.uint16, 200 * 257))
    assert np.array_equal(e8, ef) and np.array_equal(e8, e16)


def test_thresholds_control_detection():
    weak = _step(high=10)  # gradient ~ 10/255 of the range
    assert canny_edges(weak, low=0.01, high=0.02).any()
    assert not canny_edges(weak, low=0.5, high=0.9).any()


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"sigma": 0}, "sigma"), ({"low": -0.1}, "low"), ({"high": 1.5}, "high"),
     ({"low": 0.3, "high": 0.2}, "low, high")],
)
def test_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        canny_edges(_step(), **kwargs)


def test_bad_types():
    with pytest.raises(TypeError, match="sigma"):
        canny_edges(_step(), sigma="1")
    with pytest.raises(TypeError, match="image"):
        canny_edges(np.zeros((5, 5), bool))


def test_opencv_impl_finds_the_same_step_edge():
    sk = canny_edges(_step())
    cv = canny_edges(_step(), impl="opencv")
    assert cv.dtype == np.bool_ and cv.shape == sk.shape
    # both mark the step, between columns 11 and 12, on the inner rows, and nothing far away
    assert cv[4:20, 11:13].any(axis=1).all()
    assert not cv[:, :9].any() and not cv[:, 15:].any()
    assert not canny_edges(np.full((20, 20), 90, np.uint8), impl="opencv").any()


def test_opencv_impl_border_cleared_and_thresholds_mapped():
    rng = np.random.default_rng(3)
    img = (rng.random((40, 48)) * 255).astype(np.uint8)
    e = canny_edges(img, impl="opencv")
    assert e.any()
    assert not (e[0].any() or e[-1].any() or e[:, 0].any() or e[:, -1].any())
    # the same fractions mean the same for uint8 and the 0..1 float image
    assert np.array_equal(e, canny_edges(img.astype(np.float64) / 255, impl="opencv"))
    weak = _step(high=20)  # gradient of a 20-level step: well above 1 %, well below 50 %
    assert canny_edges(weak, low=0.01, high=0.02, impl="opencv").any()
    assert not canny_edges(weak, low=0.5, high=0.9, impl="opencv").any()


def test_opencv_impl_agrees_closely_with_skimage_on_texture():
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(5)
    img = np.clip(gaussian_filter(rng.random((64, 64)), 2.0) * 2000 - 900, 0, 255).astype(np.uint8)
    sk, cv = canny_edges(img), canny_edges(img, impl="opencv")
    assert sk.sum() > 50
    assert (sk & cv).sum() / (sk | cv).sum() > 0.7  # about 0.86-0.91 on Middlebury


def test_bad_impl():
    with pytest.raises(ValueError, match="impl"):
        canny_edges(_step(), impl="cv2")
