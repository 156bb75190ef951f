"""Camera models of a real rig: distortion and its inverse, the fold bound, rig errors (no GL)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereoforge.errors import ConfigError, ParameterError, StereoforgeError
from stereoforge.validation import check_distortion
from synth.camera.lens import Defocus, Distortion, RigErrors, distort, rotation_matrix, undistort
from synth.dataset.config.parse import load_config, loads_config
from synth.camera.rig import StereoRig

MILD = (-0.12, 0.03, 0.0005, -0.0008, 0.001)


def test_distort_is_opencv_projectpoints() -> None:
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-0.6, 0.6, (2, 50))
    want, _ = cv2.projectPoints(np.stack([x, y, np.ones(50)], 1), np.zeros(3), np.zeros(3),
                                np.eye(3), np.array(MILD))
    got = np.stack(distort(x, y, MILD), 1)
    np.testing.assert_allclose(got, want[:, 0], atol=1e-12)


@given(st.floats(-0.6, 0.6), st.floats(-0.45, 0.45))
def test_undistort_inverts_distort(x: float, y: float) -> None:
    ux, uy = undistort(*distort(np.array([x]), np.array([y]), MILD), MILD)
    assert abs(ux[0] - x) < 1e-12 and abs(uy[0] - y) < 1e-12


def reference_undistort(xd, yd, coeffs, iters=60, tol=1e-13):
    """``undistort``'s Newton iteration over whole arrays (it steps a block of points at a
    time; the bits must be these)."""
    xd, yd = np.asarray(xd, np.float64), np.asarray(yd, np.float64)
    if not any(coeffs):
        return xd.copy(), yd.copy()
    k1, k2, p1, p2, k3 = coeffs
    x, y = xd.copy(), yd.copy()
    for _ in range(iters):
        fx, fy = distort(x, y, coeffs)
        ex, ey = fx - xd, fy - yd
        if max(float(np.abs(ex).max(initial=0)), float(np.abs(ey).max(initial=0))) < tol:
            return x, y
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        a = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x
        b = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y
        d = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x
        det = a * d - b * b
        x = x - (d * ex - b * ey) / det
        y = y - (a * ey - b * ex) / det
    raise AssertionError("no convergence")


@pytest.mark.parametrize("coeffs", [MILD, (-0.3, 0.1, 0.002, 0.001, -0.01),
                                    (0.1, -0.02, 0.0, 0.0, 0.01)])
@pytest.mark.parametrize("shape", [(300, 257), (7,), (), (0, 4)])
def test_compiled_undistort_is_the_whole_array_iteration(coeffs, shape) -> None:
    """The compiled steps change no bit: the same operations, the same number of steps (the
    error test is over every point)."""
    rng = np.random.default_rng(len(shape))
    xd, yd = rng.uniform(-0.7, 0.7, shape), rng.uniform(-0.5, 0.5, shape)
    xd.flat[:1] = 0.69  # the slowest point decides how many steps every point takes
    got, want = undistort(xd, yd, coeffs), reference_undistort(xd, yd, coeffs)
    for g, w in zip(got, want):
        assert g.shape == w.shape == np.shape(xd) and g.tobytes() == w.tobytes()


def test_undistort_of_a_nan_does_not_converge_as_numpy_would_not() -> None:
    xd = np.array([0.1, np.nan, 0.2])
    for undo in (undistort, reference_undistort):
        with pytest.raises((ParameterError, AssertionError)):
            undo(xd, np.zeros(3), MILD)
    with pytest.raises(ParameterError, match="did not converge"):
        undistort(xd, np.zeros(3), MILD)


def reference_bilinear(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``synth.camera.imperfect._bilinear`` over whole (..., c) arrays."""
    h, w = image.shape[:2]
    x, y = np.clip(x, 0.0, w - 1.0), np.clip(y, 0.0, h - 1.0)
    x0 = np.minimum(np.floor(x).astype(np.intp), w - 2)
    y0 = np.minimum(np.floor(y).astype(np.intp), h - 2)
    tx, ty = (x - x0)[..., None], (y - y0)[..., None]
    img = image.astype(np.float64)
    top = img[y0, x0] * (1 - tx) + img[y0, x0 + 1] * tx
    bottom = img[y0 + 1, x0] * (1 - tx) + img[y0 + 1, x0 + 1] * tx
    return top * (1 - ty) + bottom * ty


@pytest.mark.parametrize(("h", "w", "shape"), [(61, 97, (150, 230)), (2, 2, (9,)),
                                               (40, 3, (5, 4))])
def test_bilinear_in_blocks_is_the_whole_array_formula(h: int, w: int, shape) -> None:
    from synth.camera.imperfect import _bilinear

    rng = np.random.default_rng(h)
    image = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    # beyond the edges (clamped), on them, on integer and half pixels
    x = rng.uniform(-3.0, w + 2.0, shape)
    y = rng.uniform(-3.0, h + 2.0, shape)
    x.flat[:4], y.flat[:4] = (0.0, w - 1.0, 2.0, w - 1.5), (h - 1.0, 0.0, 1.5, h - 1.0)
    got, want = _bilinear(image, x, y), reference_bilinear(image, x, y)
    assert got.shape == want.shape == (*shape, 3) and got.tobytes() == want.tobytes()
    with pytest.raises(ValueError, match="at least 2 x 2"):
        _bilinear(image[:1], x, y)


@pytest.mark.parametrize("s", [1, 2, 3])
def test_block_mean_is_numpys_mean(s: int) -> None:
    from synth.camera.imperfect import _block_mean

    rng = np.random.default_rng(s)
    samples = rng.uniform(0.0, 255.0, (37, s, 53, s, 3)) * rng.uniform(0.5, 1.5, (37, s, 1, 1, 1))
    want = samples.mean(axis=(1, 3))
    got = _block_mean(samples)
    assert got.shape == want.shape and got.tobytes() == want.tobytes()


def test_rotation_matrix_is_a_rotation_in_zyx_order() -> None:
    r = rotation_matrix((3.0, -2.0, 1.0))
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-15)
    want = cv2.Rodrigues(np.array([0.0, 0.0, np.radians(1.0)]))[0] @ cv2.Rodrigues(
        np.array([0.0, np.radians(-2.0), 0.0]))[0] @ cv2.Rodrigues(np.array([np.radians(3.0), 0, 0]))[0]
    np.testing.assert_allclose(r, want, atol=1e-15)


# ---------------------------------------------------------------------------- bad input
def test_folding_radial_distortion_is_refused_with_the_bound() -> None:
    # 64 x 48, fx = 60: corner radius 0.67; k1 = -0.8 stops increasing at r = 0.645 (g = 0.43)
    with pytest.raises(ParameterError) as info:
        StereoRig(width=64, height=48, fx=60.0, fy=60.0, cx=31.5, cy=23.5, baseline=0.1,
                  errors=RigErrors(left=Distortion(k1=-0.8)))
    msg = str(info.value)
    assert "left distortion: expected a distortion that does not fold the image" in msg
    assert "distorted radius 0.6667" in msg and "stops increasing at r = 0.6455" in msg
    assert "reduce |k1|, |k2|, |k3|" in msg


def test_bound_is_where_the_radial_mapping_turns() -> None:
    # g(r) = r (1 + k1 r^2): g' = 0 at r^2 = -1 / (3 k1), g there = (2/3) r: the largest corner
    k1 = -0.5
    r_f = np.sqrt(-1 / (3 * k1))
    bound = r_f * (1 + k1 * r_f**2)
    check_distortion((k1, 0, 0, 0, 0), "k", max_radius=bound * 0.999)
    with pytest.raises(ParameterError, match="does not fold"):
        check_distortion((k1, 0, 0, 0, 0), "k", max_radius=bound * 1.001)
    # a pincushion k1 > 0 with k2 < 0 folds too; k1 > 0 alone never does
    with pytest.raises(ParameterError, match="does not fold"):
        check_distortion((0.3, -0.6, 0, 0, 0), "k", max_radius=1.0)
    check_distortion((0.5, 0, 0, 0, 0), "k", max_radius=5.0)


def test_folding_tangential_distortion_is_refused() -> None:
    with pytest.raises(ParameterError, match=r"k p1: expected \|p1\| <= 0.05, got 0.2"):
        check_distortion((0, 0, 0.2, 0, 0), "k", max_radius=0.5)
    with pytest.raises(ParameterError, match="positive Jacobian"):
        check_distortion((0.0, 0.0, 0.05, 0.05, 0.0), "k", max_radius=3.0)  # fold near r = 3
    check_distortion((0.0, 0.0, 0.05, 0.05, 0.0), "k", max_radius=2.0)


@pytest.mark.parametrize("rotation", [(30.0, 0.0, 0.0), (0.0, 0.0, -11.0), (0.0, 3.14, 1e9)])
def test_absurd_rotation_is_refused(rotation) -> None:
    with pytest.raises(ParameterError, match=r"rotation_deg\[\d\]: expected a rotation within "
                                              r"\+-10.0 degrees.*degrees, not radians"):
        RigErrors(rotation_deg=rotation)


def test_config_errors_name_file_line_and_bound() -> None:
    text = "[rig]\nwidth = 64\nheight = 48\nk1 = -1.5\n"
    with pytest.raises(ConfigError, match=r"^my.toml:4: \[rig\] left distortion: expected a "
                                          r"distortion that does not fold"):
        loads_config(text, source="my.toml")
    with pytest.raises(ConfigError, match=r"my.toml:2: rig.right_rx_deg: expected a finite number in "
                                          r"\[-10.0, 10.0\]"):
        loads_config("[rig]\nright_rx_deg = 45\n", source="my.toml")
    with pytest.raises(ConfigError, match="focus_distance and f_number: expected both"):
        loads_config("[rig]\nfocus_distance = 2.0\n", source="my.toml")


def test_every_error_is_a_stereoforge_error() -> None:
    for bad in (lambda: RigErrors(f_scale=2.0), lambda: Defocus(2.0, 0.1),
                lambda: RigErrors(rotation_deg=(1.0, 2.0))):
        with pytest.raises(StereoforgeError):
            bad()


# ---------------------------------------------------------------------------- the rig
def test_ideal_rig_keeps_todays_dict_and_round_trips_errors() -> None:
    rig = StereoRig.default(64, 48)
    assert "errors" not in rig.to_dict() and rig.ideal is rig
    real = StereoRig(**{**rig.to_dict(), "errors": RigErrors(
        left=Distortion(*MILD), rotation_deg=(0.3, -0.2, 0.1), dy_px=0.5, f_scale=1.01,
        defocus=Defocus(2.0, 2.8))})
    assert StereoRig.from_dict(real.to_dict()) == real
    assert real.ideal == rig
    assert real.scaled(2.0).errors.dy_px == 1.0


def test_shipped_imperfect_rig_config() -> None:
    cfg = load_config("imperfect-rig")
    e = cfg.rig.errors
    assert e is not None and e.geometric and e.defocus is None
    assert cfg.rig.fy != cfg.rig.fx and not e.left.is_zero and any(e.rotation_deg)
    assert all(d.to_toml() == 0.0 or d.to_toml() == 1.0 for d in cfg.photometric.values())
    assert loads_config(
        "[rig]\n" + "".join(f"{k} = {v}\n" for k, v in cfg.to_dict()["rig"].items())).rig == cfg.rig


def test_coc_is_the_thin_lens_formula() -> None:
    # f = 1000 px * 5 um = 5 mm, N = 2: A = 2.5 mm; S = 2 m, Z = 1 m: c = A f / (S - f) |Z-S|/Z
    c = Defocus(2.0, 2.0, 5.0).coc_px(np.array([2.0, 1.0, np.inf]), fx=1000.0)
    want = 2.5e-3 * 5e-3 / (2.0 - 5e-3) * np.array([0.0, 1.0, 1.0]) / 5e-6
    np.testing.assert_allclose(c, want, rtol=1e-12)


def test_a_dataset_of_real_cameras_refuses_the_kitti_layout_before_rendering(tmp_path) -> None:
    from stereoforge.errors import DatasetError
    from synth.dataset import run_dataset

    cfg = loads_config("[rig]\nwidth = 64\nheight = 48\nright_rz_deg = 0.5\n", source="r.toml")
    with pytest.raises(DatasetError, match=r"^r.toml: .*flow0.flo.*KITTI 2015 layout cannot hold; "
                                           r"use --format middlebury"):
        run_dataset(cfg, out=tmp_path / "ds", count=1, fmt="kitti", progress=False)
    assert not (tmp_path / "ds").exists()


def test_fy_alone_is_an_ideal_rig_with_non_square_pixels() -> None:
    cfg = loads_config("[rig]\nwidth = 64\nheight = 48\nfy = 61.5\n")
    assert (cfg.rig.fx, cfg.rig.fy, cfg.rig.errors) == (60.0, 61.5, None)
    assert cfg.to_dict()["rig"]["fy"] == 61.5
    assert "fy" not in loads_config("[rig]\nwidth = 64\nheight = 48\n").to_dict()["rig"]
