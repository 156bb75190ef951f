"""StereoRig: validation, conventions, depth <-> disparity, scaling, calib fields."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from matcher.io import format_calib
from synth.camera.rig import StereoRig


def test_default_is_centred_and_scales_focal() -> None:
    rig = StereoRig.default(640, 480)
    assert (rig.fx, rig.fy, rig.cx, rig.cy, rig.baseline) == (600.0, 600.0, 319.5, 239.5, 0.1)
    small = StereoRig.default(64, 48, baseline=0.2)
    assert (small.fx, small.cx, small.cy, small.baseline) == (60.0, 31.5, 23.5, 0.2)
    assert StereoRig.default(64, 48, fx=100.0).fy == 100.0


def test_K() -> None:
    rig = StereoRig(width=10, height=8, fx=5.0, fy=6.0, cx=4.0, cy=3.0, baseline=1.0)
    np.testing.assert_array_equal(rig.K(), [[5, 0, 4], [0, 6, 3], [0, 0, 1]])
    assert rig.K().dtype == np.float64


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("width", 0, r"StereoRig\.width: expected an integer > 0, got 0; pass the image width"),
        ("height", -3, r"height: expected an integer > 0, got -3"),
        ("fx", 0.0, r"fx: expected a finite number > 0, got 0\.0; pass a positive value in pixels"),
        ("fy", -1.0, r"fy: expected a finite number > 0, got -1\.0"),
        ("baseline", 0.0, r"baseline: expected a finite number > 0, got 0\.0; .* in metres"),
        ("near", 0.0, "0 < near < far"),
        ("far", 0.05, "0 < near < far"),
        ("cx", math.nan, r"StereoRig\.cx: expected a finite number, got nan"),
    ],
)
def test_validation_names_parameter(field: str, value: float, message: str) -> None:
    args = dict(width=8, height=6, fx=5.0, fy=5.0, cx=3.5, cy=2.5, baseline=0.1)
    args[field] = value
    with pytest.raises(ValueError, match=message):
        StereoRig(**args)


def test_width_must_be_int() -> None:
    with pytest.raises(TypeError, match=r"width: expected an integer > 0, got float 8\.0"):
        StereoRig(width=8.0, height=6, fx=5.0, fy=5.0, cx=3.5, cy=2.5, baseline=0.1)


def test_depth_disparity_examples() -> None:
    rig = StereoRig.default(64, 48, baseline=0.5)  # fx * B = 30
    np.testing.assert_array_equal(
        rig.disparity_from_depth([1.0, 2.0, np.inf, 0.0, -1.0, np.nan]),
        [30.0, 15.0, np.inf, np.inf, np.inf, np.inf],
    )
    np.testing.assert_array_equal(
        rig.depth_from_disparity([30.0, 15.0, np.inf, 0.0, -1.0, np.nan]),
        [1.0, 2.0, np.inf, np.inf, np.inf, np.inf],
    )


@given(z=st.floats(1e-3, 1e4), fx=st.floats(1.0, 5000.0), b=st.floats(1e-3, 2.0))
def test_depth_disparity_round_trip(z: float, fx: float, b: float) -> None:
    rig = StereoRig(width=8, height=6, fx=fx, fy=fx, cx=3.5, cy=2.5, baseline=b)
    d = rig.disparity_from_depth(z)
    assert float(d) == pytest.approx(fx * b / z, rel=1e-15)
    assert float(rig.depth_from_disparity(d)) == pytest.approx(z, rel=1e-12)


def test_disparity_uses_fx_on_non_square_pixels() -> None:
    """d = fx * B / Z with fx != fy (disparity is horizontal: fy plays no part)."""
    rig = StereoRig(width=64, height=48, fx=60.0, fy=45.0, cx=31.5, cy=23.5, baseline=0.1)
    assert float(rig.disparity_from_depth(2.0)) == 3.0  # 60 * 0.1 / 2 exactly; fy would give 2.25
    assert float(rig.depth_from_disparity(3.0)) == 2.0
    assert rig.middlebury_calib(ndisp=16, vmin=0, vmax=3)["baseline"] == 100.0  # mm


def test_scaled_example() -> None:
    rig = StereoRig(width=64, height=48, fx=60.0, fy=50.0, cx=31.5, cy=20.0, baseline=0.1)
    half = rig.scaled(0.5)
    assert (half.width, half.height, half.fx, half.fy) == (32, 24, 30.0, 25.0)
    assert (half.cx, half.cy) == (15.5, 9.75)  # (cx + 0.5) / 2 - 0.5
    assert half.baseline == rig.baseline
    with pytest.raises(ValueError, match="whole numbers"):
        rig.scaled(0.3)


@given(
    factor=st.sampled_from([0.25, 0.5, 2.0, 3.0]),
    cx=st.floats(-10, 70),
    X=st.floats(-2, 2),
    Z=st.floats(0.5, 10),
)
def test_scaled_keeps_pixel_areas(factor: float, cx: float, X: float, Z: float) -> None:
    """A point's image position maps like the pixel grid: x' = (x + 0.5) * s - 0.5."""
    rig = StereoRig(width=64, height=48, fx=60.0, fy=60.0, cx=cx, cy=23.5, baseline=0.1)
    small = rig.scaled(factor)
    x = rig.fx * X / Z + rig.cx
    x_small = small.fx * X / Z + small.cx
    assert x_small == pytest.approx((x + 0.5) * factor - 0.5, abs=1e-9)
    assert float(small.disparity_from_depth(Z)) == pytest.approx(
        factor * float(rig.disparity_from_depth(Z)), rel=1e-12
    )


def test_dict_round_trip_and_unknown_keys() -> None:
    rig = StereoRig(width=64, height=48, fx=61.25, fy=59.0, cx=30.0, cy=22.0, baseline=0.12,
                    near=0.5, far=50.0)
    assert StereoRig.from_dict(rig.to_dict()) == rig
    with pytest.raises(ValueError, match=r"unknown key 'skew' in StereoRig\.from_dict; "
                                         r"valid keys: \['width', "):
        StereoRig.from_dict({**rig.to_dict(), "skew": 0.0})


def test_middlebury_calib_fields() -> None:
    rig = StereoRig(width=64, height=48, fx=60.0, fy=60.0, cx=31.5, cy=23.25, baseline=0.1)
    calib = rig.middlebury_calib(ndisp=32, vmin=2.0, vmax=9.5)
    assert list(calib) == ["cam0", "cam1", "doffs", "baseline", "width", "height", "ndisp",
                           "vmin", "vmax"]
    assert calib["cam0"].tolist() == [[60, 0, 31.5], [0, 60, 23.25], [0, 0, 1]]
    assert np.array_equal(calib["cam1"], calib["cam0"])
    assert format_calib(calib).splitlines()[0] == "cam0=[60 0 31.5; 0 60 23.25; 0 0 1]"
    assert calib["baseline"] == pytest.approx(100.0)  # millimetres
    assert (calib["width"], calib["height"], calib["ndisp"], calib["doffs"]) == (64, 48, 32, 0.0)
    shifted = rig.middlebury_calib(32, 2.0, 9.5, doffs=4.0)
    assert shifted["cam1"].tolist() == [[60, 0, 35.5], [0, 60, 23.25], [0, 0, 1]]
    with pytest.raises(ValueError, match="vmin <= vmax"):
        rig.middlebury_calib(32, 9.0, 2.0)
    assert rig.middlebury_calib(32, 0.0, 9.5)["vmin"] == 0.0  # 0 is a valid bound
    with pytest.raises(ValueError, match=r"ndisp: expected an integer > 0, got bool True"):
        rig.middlebury_calib(True, 2.0, 9.5)
    with pytest.raises(ValueError, match=r"vmin: expected a finite number >= 0, got -1\.0"):
        rig.middlebury_calib(32, -1.0, 9.5)
