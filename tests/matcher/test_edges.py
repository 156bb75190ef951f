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
