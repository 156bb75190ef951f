"""The shared validation helpers of ``matcher._validation`` (used by io, metrics and the matchers)."""

from __future__ import annotations

import numpy as np
import pytest

from matcher._validation import (
    GREY_WEIGHTS,
    check_disparity_map,
    check_ground_truth,
    check_image,
    check_max_disparity,
    check_occlusion_mask,
    check_same_shape,
    check_window,
)


def test_check_image_grey_passthrough_and_rgb_conversion():
    grey = np.arange(6, dtype=np.uint8).reshape(2, 3)
    assert check_image(grey, "left") is grey
    rgb = np.zeros((1, 3, 3), np.uint8)
    rgb[0, 0] = (255, 0, 0)
    rgb[0, 1] = (0, 255, 0)
    rgb[0, 2] = (10, 20, 30)
    out = check_image(rgb, "left")
    assert out.dtype == np.uint8
    expected = [round(255 * GREY_WEIGHTS[0]), round(255 * GREY_WEIGHTS[1]),
                round(10 * 0.299 + 20 * 0.587 + 30 * 0.114)]
    assert out.tolist() == [expected]  # [76, 150, 18]
    f = check_image(rgb.astype(np.float32) / 255, "left")
    assert f.dtype == np.float32
    np.testing.assert_allclose(f * 255, [[76.245, 149.685, 18.15]], rtol=1e-5)


def test_check_image_other_integers_become_float64_and_channel_axis_dropped():
    assert check_image(np.ones((2, 2), np.uint16), "x").dtype == np.float64
    assert check_image(np.ones((2, 2, 1), np.uint8), "x").shape == (2, 2)


@pytest.mark.parametrize(
    ("image", "error", "message"),
    [
        ([[1, 2]], TypeError, "left: expected a numpy array"),
        (np.zeros((2, 2), bool), TypeError, "dtype bool"),
        (np.zeros((2, 2), complex), TypeError, "complex"),
        (np.zeros((2, 2, 4), np.uint8), ValueError, "alpha"),
        (np.zeros(4, np.uint8), ValueError, r"\(H, W\)"),
        (np.zeros((0, 3), np.uint8), ValueError, "non-empty"),
        (np.array([[0.0, np.nan]]), ValueError, "1 NaN/inf"),
    ],
)
def test_check_image_errors(image, error, message):
    with pytest.raises(error, match=message):
        check_image(image, "left")


def test_check_same_shape():
    check_same_shape(np.zeros((2, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"left and right: expected the same shape, got \(2, 3\) and \(3, 2\)"):
        check_same_shape(np.zeros((2, 3)), np.zeros((3, 2)))


def test_check_window():
    assert check_window(np.int64(3), "window", image_shape=(3, 10)) == 3
    with pytest.raises(ValueError, match="odd integer >= 3, got 4; try 5"):
        check_window(4, "window", image_shape=(9, 9))
    with pytest.raises(ValueError, match="odd integer >= 3, got 1"):
        check_window(1, "window", image_shape=(9, 9))
    with pytest.raises(ValueError, match="at most min"):
        check_window(11, "window", image_shape=(9, 20))
    with pytest.raises(TypeError, match="integer"):
        check_window(5.0, "window", image_shape=(9, 9))
    with pytest.raises(TypeError, match="integer"):
        check_window(True, "window", image_shape=(9, 9))


def test_check_max_disparity():
    assert check_max_disparity(1, 2) == 1
    for bad in (0, 2, -3):
        with pytest.raises(ValueError, match=r"max_disparity: expected an integer in \[1, 1\]"):
            check_max_disparity(bad, 2)
    with pytest.raises(TypeError):
        check_max_disparity(1.5, 10)


def test_check_disparity_map():
    d = np.zeros((2, 2), np.float32)
    assert check_disparity_map(d, "d") is d
    assert check_disparity_map(np.zeros((2, 2), np.int16), "d", allow_integer=True).dtype == np.float64
    with pytest.raises(TypeError, match="mark invalid pixels with inf"):
        check_disparity_map(np.zeros((2, 2), np.int16), "d")
    with pytest.raises(ValueError, match=r"expected shape \(3, 3\)"):
        check_disparity_map(d, "d", shape=(3, 3))


def test_check_occlusion_mask_and_ground_truth():
    mask = check_occlusion_mask(np.array([[255, 128, 0]], np.uint8), "m")
    out = check_ground_truth(np.array([[1.0, 2.0, np.nan]]), "d", mask=mask)
    assert out.dtype == np.float32 and out.tolist() == [[1.0, 2.0, np.inf]]
    with pytest.raises(ValueError, match=r"got also \[1\]"):
        check_occlusion_mask(np.array([[1]], np.uint8), "m")
    with pytest.raises(ValueError, match="at row 0, column 0"):
        check_ground_truth(np.array([[-0.5, 1.0, np.inf]]), "d")
    with pytest.raises(ValueError, match=">= 0"):
        check_ground_truth(np.array([[-np.inf]]), "d")
    with pytest.raises(ValueError, match="mask is 0 and d is 3.0"):
        check_ground_truth(np.array([[1.0, 2.0, 3.0]]), "d", mask=mask)
    with pytest.raises(ValueError, match="mask is 128 and d is inf"):
        check_ground_truth(np.array([[1.0, np.inf, np.inf]]), "d", mask=mask)
