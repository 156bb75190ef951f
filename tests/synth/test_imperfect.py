"""Exactness of the flow of an imperfect rig: closed form on planes, warping, ray casting.

The flow of ``render_pair`` (``synth.camera.imperfect.camera_flow``) is checked against code that shares
none of it: the plane-induced homography with OpenCV's ``projectPoints`` and a fixed-point
undistortion (closed form), the right image warped onto the left (the images are rendered
separately from the flow), and brute-force float64 ray-triangle tests (ray casting).
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest
import scenes

from hypothesis import given
from hypothesis import strategies as st

from matcher.io import read_flo, read_image
from synth.camera.lens import Defocus, Distortion, RigErrors, rotation_matrix
from synth.write.export import OutputDirError, write_pair
from synth.pair import render_pair
from synth.render.renderer import Renderer
from synth.camera.rig import StereoRig
from synth.testing import rig_errors
from synth.appearance.texture_control import retexture

pytestmark = pytest.mark.gl

TOL_PX = 1e-5  # |flow - independent| (px); we observe 1.2e-7 px, the float32 rounding of the flow
ERRORS = {
    "rotation": RigErrors(rotation_deg=(0.6, -0.8, 0.5)),
    "all": RigErrors(left=Distortion(-0.15, 0.04, 0.0008, -0.0006, 0.002),
                     right=Distortion(-0.1, 0.02, -0.0005, 0.0004, 0.0),
                     rotation_deg=(0.4, -0.5, 0.3), dy_px=1.5, f_scale=1.01),
}
RIG = StereoRig(width=64, height=48, fx=60.0, fy=61.0, cx=31.2, cy=23.9, baseline=0.1)


def _real(rig: StereoRig, errors: RigErrors) -> StereoRig:
    return dataclasses.replace(rig, errors=errors)


def _undistort_fixed_point(u, v, fx, fy, cx, cy, coeffs, iters=400):
    """OpenCV's cvUndistortPoints iteration (not Newton), run to convergence."""
    k1, k2, p1, p2, k3 = coeffs
    xd, yd = (u - cx) / fx, (v - cy) / fy
    x, y = xd.copy(), yd.copy()
    for _ in range(iters):
        r2 = x * x + y * y
        radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
        dx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        dy = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        x, y = (xd - dx) / radial, (yd - dy) / radial
    return x, y


def _opencv_project(points: np.ndarray, rig: StereoRig, e: RigErrors) -> np.ndarray:
    """World points -> right pixels by cv2.projectPoints (R^T, -R^T o)."""
    r_t = rotation_matrix(e.rotation_deg).T
    k = np.array([[rig.fx * e.f_scale, 0, rig.cx], [0, rig.fy * e.f_scale, rig.cy + e.dy_px],
                  [0, 0, 1]])
    rvec = cv2.Rodrigues(r_t)[0]
    tvec = -r_t @ np.array([rig.baseline, 0.0, 0.0])
    out, _ = cv2.projectPoints(points.reshape(-1, 1, 3), rvec, tvec, k, np.array(e.right.coeffs))
    return out.reshape(points.shape[:-1] + (2,))


def _check_plane_flow(pair, spec, rig: StereoRig, e: RigErrors) -> None:
    n, c = scenes.plane_equation(spec.objects[0])
    v, u = np.mgrid[0:rig.height, 0:rig.width].astype(np.float64)
    x, y = _undistort_fixed_point(u, v, rig.fx, rig.fy, rig.cx, rig.cy, e.left.coeffs)
    ray = np.stack([x, y, np.ones_like(x)], -1)
    point = ray * (c / (ray @ n))[..., None]  # the plane n . X = c along the ray
    want = _opencv_project(point, rig, e) - np.stack([u, v], -1)
    valid = np.isfinite(pair.flow_left).all(-1)
    assert valid.mean() > 0.8  # the plane fills the view; only the borders leave it
    assert np.abs(pair.flow_left[valid] - want[valid]).max() <= TOL_PX
    inside = ((want[..., 0] + u >= -0.5) & (want[..., 0] + u <= rig.width - 0.5)
              & (want[..., 1] + v >= -0.5) & (want[..., 1] + v <= rig.height - 0.5))
    np.testing.assert_array_equal(valid, inside)  # a plane occludes nothing of itself


@pytest.mark.parametrize("preset", ["fronto_plane", "slanted_plane"])
@pytest.mark.parametrize("name", list(ERRORS))
def test_plane_flow_matches_closed_form(renderer: Renderer, preset: str, name: str) -> None:
    e = ERRORS[name]
    spec = scenes.get_preset(preset)
    pair = render_pair(spec, _real(RIG, e), renderer=renderer)
    _check_plane_flow(pair, spec, RIG, e)
    # the ground truth stays the ideal rig's
    ideal = render_pair(spec, RIG, renderer=renderer)
    np.testing.assert_array_equal(pair.disp_left, ideal.disp_left)
    np.testing.assert_array_equal(pair.mask_left, ideal.mask_left)


@given(e=rig_errors(), preset=st.sampled_from(["fronto_plane", "slanted_plane"]))
def test_plane_flow_matches_closed_form_properties(renderer: Renderer, e: RigErrors,
                                                   preset: str) -> None:
    """The same for drawn errors (a property beside the hand-picked cases above)."""
    rig = StereoRig(width=32, height=24, fx=30.0, fy=30.4, cx=15.7, cy=11.2, baseline=0.1)
    spec = scenes.get_preset(preset)
    _check_plane_flow(render_pair(spec, _real(rig, e), renderer=renderer), spec, rig, e)


def test_fronto_plane_rotation_flow_by_hand(renderer: Renderer) -> None:
    # plane Z = 2, fx = fy = 60, B = 0.1, right camera panned by a = 0.5 deg (about y): pixel
    # (31, 23) sees P = 2 (-0.5/60, -0.5/60, 1); in the right camera R^T (P - o) with
    # R^T = [[cos a, 0, -sin a], [0, 1, 0], [sin a, 0, cos a]]
    rig = StereoRig.default(64, 48)
    pair = render_pair(scenes.get_preset("fronto_plane"),
                       _real(rig, RigErrors(rotation_deg=(0.0, 0.5, 0.0))), renderer=renderer)
    c, s = np.cos(np.radians(0.5)), np.sin(np.radians(0.5))
    px, py = -1.0 / 60.0 - 0.1, -1.0 / 60.0
    xc, zc = c * px - s * 2.0, s * px + c * 2.0
    want = (60.0 * xc / zc + 31.5 - 31.0, 60.0 * py / zc + 23.5 - 23.0)
    np.testing.assert_allclose(pair.flow_left[23, 31], want, atol=TOL_PX)
    assert want[0] < -3.5  # the pan adds about 60 px * 0.0087 = 0.52 px to the 3 px disparity


def _warp(right: np.ndarray, flow: np.ndarray) -> np.ndarray:
    h, w = flow.shape[:2]
    v, u = np.mgrid[0:h, 0:w].astype(np.float32)
    fx = np.nan_to_num(u + flow[..., 0], nan=-10.0)
    fy = np.nan_to_num(v + flow[..., 1], nan=-10.0)
    return cv2.remap(right.astype(np.float32), fx, fy, cv2.INTER_CUBIC,
                     borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))


def _smooth(flow: np.ndarray, tol: float = 0.3) -> np.ndarray:
    """Valid pixels whose 3 x 3 neighbours are valid with flows within ``tol`` px (no edge)."""
    ok = np.isfinite(flow).all(-1)
    pad = np.pad(flow, ((1, 1), (1, 1), (0, 0)), constant_values=np.nan)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            nb = pad[1 + dy:1 + dy + flow.shape[0], 1 + dx:1 + dx + flow.shape[1]]
            with np.errstate(invalid="ignore"):
                ok &= (np.abs(nb - flow) <= tol).all(-1)
    ok[[0, -1]] = False
    ok[:, [0, -1]] = False
    return ok


def warp_residuals(left: np.ndarray, right: np.ndarray, flow: np.ndarray) -> tuple[float, float]:
    """Mean |left - right warped by flow| on smooth valid pixels, and the same with the flow
    shifted by 0.5 px (how much a wrong flow costs)."""
    keep = _smooth(flow)
    assert keep.mean() > 0.4, "too few pixels away from edges to test"
    good = np.abs(_warp(right, flow) - left)[keep].mean()
    bad = np.abs(_warp(right, flow + np.float32([0.0, 0.5])) - left)[keep].mean()
    return float(good), float(bad)


@pytest.mark.parametrize("preset", ["slanted_plane", "boxes"])
def test_right_image_warped_by_the_flow_is_the_left(renderer: Renderer, preset: str) -> None:
    rig = StereoRig.default(128, 96)
    spec = retexture(scenes.get_preset(preset), fx=rig.fx, frequency_px=0.06, contrast=0.8)
    pair = render_pair(spec, _real(rig, ERRORS["all"]), renderer=renderer)
    good, bad = warp_residuals(pair.left.astype(np.float32), pair.right, pair.flow_left)
    assert good <= 1.0 and bad >= 3 * good, (good, bad)  # grey levels (0..255)


def _brute_force_hits(tris: np.ndarray, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Ray parameter of the nearest hit of each ray over all triangles (Moller-Trumbore, float64,
    no acceleration structure), inf where none."""
    v0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    best = np.full(len(dirs), np.inf)
    for k in range(0, len(dirs), 256):
        o, d = origins[k:k + 256, None], dirs[k:k + 256, None]
        p = np.cross(d, e2)
        det = np.einsum("rtk,tk->rt", p, e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            s = o - v0
            a = np.einsum("rtk,rtk->rt", s, p) * inv
            q = np.cross(s, e1)
            b = np.einsum("rtk,rtk->rt", d, q) * inv
            t = np.einsum("rtk,tk->rt", q, e2) * inv
        ok = (np.abs(det) > 1e-14) & (a >= 0) & (b >= 0) & (a + b <= 1) & (t > 1e-9)
        best[k:k + 256] = np.where(ok, t, np.inf).min(axis=1)
    return best


def _independent_flow(meshes, rig: StereoRig, e: RigErrors) -> np.ndarray:
    """Flow by brute-force ray-triangle tests, fixed-point undistortion and OpenCV."""
    tris = np.concatenate([np.asarray(m.vertices, np.float64)[m.faces] for m in meshes])
    v, u = np.mgrid[0:rig.height, 0:rig.width].astype(np.float64)
    x, y = _undistort_fixed_point(u, v, rig.fx, rig.fy, rig.cx, rig.cy, e.left.coeffs)
    dirs = np.stack([x, y, np.ones_like(x)], -1).reshape(-1, 3)
    t = _brute_force_hits(tris, np.zeros_like(dirs), dirs)
    points = dirs * t[:, None]
    o = np.array([rig.baseline, 0.0, 0.0])
    hit = np.isfinite(t)
    to = points[hit] - o
    dist = np.linalg.norm(to, axis=1)
    seen = _brute_force_hits(tris, np.broadcast_to(o, to.shape), to / dist[:, None])
    visible = np.zeros(len(dirs), bool)
    visible[np.flatnonzero(hit)] = np.abs(seen - dist) <= 1e-6 * dist
    xy = _opencv_project(np.where(hit[:, None], points, 1.0), rig, e)
    flow = xy - np.stack([u, v], -1).reshape(-1, 2)
    inside = ((xy[:, 0] >= -0.5) & (xy[:, 0] <= rig.width - 0.5) & (xy[:, 1] >= -0.5)
              & (xy[:, 1] <= rig.height - 0.5))
    flow[~(visible & inside)] = np.nan
    return flow.reshape(rig.height, rig.width, 2)


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["boxes", "flying"])
def test_flow_matches_independent_ray_casting(renderer: Renderer, preset: str) -> None:
    rig = StereoRig(width=40, height=30, fx=37.5, fy=37.6, cx=19.3, cy=14.6, baseline=0.1)
    spec = scenes.get_preset(preset, seed=3)
    e = ERRORS["all"]
    pair = render_pair(spec, _real(rig, e), renderer=renderer)
    want = _independent_flow(scenes.build_meshes(spec), rig, e)
    both = np.isfinite(pair.flow_left).all(-1) & np.isfinite(want).all(-1)
    assert both.mean() > 0.7
    assert np.abs(pair.flow_left[both] - want[both]).max() <= TOL_PX
    # the casters may disagree on which surface a ray grazing a silhouette meets: rare
    differ = np.isfinite(pair.flow_left).all(-1) != np.isfinite(want).all(-1)
    assert differ.mean() <= 0.02


# ---------------------------------------------------------------------------- images, files
def test_defocus_blurs_out_of_focus_depths_only(renderer: Renderer) -> None:
    rig = StereoRig.default(64, 48, fx=600.0)  # a narrow view of the plane, d = 30 px
    spec = scenes.get_preset("fronto_plane")  # Z = 2 m
    ideal = render_pair(spec, rig, renderer=renderer)
    sharp = render_pair(spec, _real(rig, RigErrors(defocus=Defocus(2.0, 1.4, 10.0))),
                        renderer=renderer)
    np.testing.assert_array_equal(sharp.left, ideal.left)  # in focus: the ideal images
    np.testing.assert_array_equal(sharp.right, ideal.right)
    blurred = render_pair(spec, _real(rig, RigErrors(defocus=Defocus(0.5, 1.4, 10.0))),
                          renderer=renderer)  # f = 6 mm, c = (f/1.4) f/(0.5 m - f) 0.75 = 3.9 px

    def energy(img):
        return float(np.abs(np.diff(img.astype(float), axis=1)).mean())

    stronger = render_pair(spec, _real(rig, RigErrors(defocus=Defocus(0.5, 0.7, 10.0))),
                           renderer=renderer)  # twice the aperture: 7.8 px
    assert energy(stronger.left) < 0.8 * energy(blurred.left) < 0.8 * 0.8 * energy(ideal.left)
    assert energy(stronger.right) < 0.8 * energy(blurred.right) < 0.8 * 0.8 * energy(ideal.right)
    np.testing.assert_allclose(blurred.flow_left[..., 0][np.isfinite(blurred.flow_left[..., 0])],
                               -30.0, atol=1e-9)  # defocus moves no geometry: u = -d


def test_write_pair_writes_flow0_and_refuses_kitti(renderer: Renderer, tmp_path) -> None:
    spec = scenes.get_preset("fronto_plane")
    pair = render_pair(spec, _real(StereoRig.default(64, 48), ERRORS["all"]), renderer=renderer)
    files = write_pair(pair, tmp_path, scene=spec, seed=0, preview=False, fsync=False)
    assert tmp_path / "flow0.flo" in files
    np.testing.assert_array_equal(read_flo(tmp_path / "flow0.flo"), pair.flow_left)
    np.testing.assert_array_equal(read_image(tmp_path / "im0.png"), pair.left)
    in_2014 = write_pair(pair, tmp_path / "2014", scene=spec, seed=0, fmt="middlebury2014",
                         preview=False, fsync=False)
    assert {"flow0.flo", "disp0.pfm"} <= {p.name for p in in_2014}
    assert (tmp_path / "2014" / "flow0.flo").read_bytes() == (tmp_path / "flow0.flo").read_bytes()
    with pytest.raises(OutputDirError, match="flow0.flo in the middlebury layouts only"):
        write_pair(pair, tmp_path / "k", scene=spec, seed=0, fmt="kitti", fsync=False)
    ideal = render_pair(spec, StereoRig.default(64, 48), renderer=renderer)
    assert ideal.flow_left is None
    assert "flow0.flo" not in {p.name for p in write_pair(ideal, tmp_path / "i", scene=spec,
                                                          seed=0, preview=False, fsync=False)}


@pytest.mark.slow
def test_imperfect_rig_dataset_warps_onto_itself(tmp_path) -> None:
    """The shipped ``imperfect-rig`` config (scaled to 128 x 96): each sample's right image,
    warped by its flow0.flo, is its left image on textured pixels away from depth edges."""
    from synth.dataset import run_dataset
    from synth.dataset.config.parse import config_from_dict, load_config

    data = load_config("imperfect-rig").to_dict()
    k = 128 / data["rig"]["width"]
    data["rig"].update(width=128, height=96, fx=data["rig"]["fx"] * k, fy=data["rig"]["fy"] * k,
                       right_dy_px=data["rig"]["right_dy_px"] * k)
    cfg = config_from_dict(data)
    shipped = load_config("imperfect-rig").rig.errors
    assert cfg.rig.errors == dataclasses.replace(shipped, dy_px=shipped.dy_px * k)
    run_dataset(cfg, out=tmp_path / "ds", count=2, workers=1, progress=False)
    for sample in sorted((tmp_path / "ds").glob("0*")):
        left = read_image(sample / "im0.png").astype(np.float32)
        right = read_image(sample / "im1.png")
        flow = read_flo(sample / "flow0.flo")
        good, bad = warp_residuals(left, right, flow)
        assert good <= 1.5 and bad >= 2 * good, (sample.name, good, bad)


def test_missing_embree_is_one_clear_error(monkeypatch) -> None:
    import trimesh.ray

    from stereoforge.errors import BackendError
    from synth.camera.imperfect import camera_flow

    monkeypatch.setattr(trimesh.ray, "has_embree", False)
    with pytest.raises(BackendError, match="embree, which is not installed; fix: pip install"):
        camera_flow(scenes.get_preset("fronto_plane"), _real(RIG, ERRORS["all"]))
