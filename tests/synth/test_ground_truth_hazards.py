"""Exact ground truth on the hazards of issue 13: thin and repetitive bars, meshes from files,
photograph textures (closed form on planes, ray casting on every pixel)."""

from __future__ import annotations

import importlib.util
import types
from pathlib import Path

import numpy as np
import pytest
import scenes
import trimesh
from scenes import ObjectSpec, Pose, SceneSpec, TextureSpec

from synth.pair import render_pair
from synth.render.renderer import Renderer
from synth.camera.rig import StereoRig

pytestmark = pytest.mark.gl

TOL_PX = 1e-3
RIG = StereoRig(width=64, height=48, fx=60.0, fy=60.0, cx=31.5, cy=23.5, baseline=0.1)


def _ground_truth_helpers() -> types.ModuleType:
    """tests/synth/test_ground_truth.py (its ray caster), loaded from its path: test modules
    are not importable by name under --import-mode=importlib."""
    path = Path(__file__).with_name("test_ground_truth.py")
    spec = importlib.util.spec_from_file_location("_gt_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_HELPERS = _ground_truth_helpers()


def _wall(z: float) -> ObjectSpec:
    return ObjectSpec("plane", Pose(translation=(0.05, 0.0, z)), scenes.presets.frame_cover_size(z),
                      TextureSpec(frequency=10.0, seed=1), name="wall")


def _bar_edges(kind: str, x0: float, y0: float, size: tuple[float, ...]
               ) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """(x edges, y edges, depth) of every bar face plane of a fence/grid centred at (x0, y0, 2)."""
    width, height, spacing, t = size
    n_x = int(np.floor(width / spacing + 1e-9)) + 1
    xs = x0 + (np.arange(n_x) - (n_x - 1) / 2) * spacing
    out = [(np.concatenate([xs - t / 2, xs + t / 2]), np.array([y0 - height / 2, y0 + height / 2]),
            depth) for depth in (2.0 - t / 2, 2.0 + t / 2)]
    if kind == "grid":
        n_y = int(np.floor(height / spacing + 1e-9)) + 1
        ys = y0 + (np.arange(n_y) - (n_y - 1) / 2) * spacing
        out += [(np.array([x0 - width / 2, x0 + width / 2]), np.concatenate([ys - t / 2, ys + t / 2]),
                 depth) for depth in (2.0 + t / 2, 2.0 + 3 * t / 2)]
    return out


def _margin(kind: str, x0: float, y0: float, size: tuple[float, ...]) -> float:
    """Smallest distance (px) from a pixel centre to the projection of any bar edge, both views."""
    worst = np.inf
    for xe, ye, z in _bar_edges(kind, x0, y0, size):
        for shift in (0.0, RIG.baseline):
            u = RIG.cx + RIG.fx * (xe - shift) / z
            v = RIG.cy + RIG.fy * ye / z
            worst = min(worst, np.abs(u - np.rint(u)).min(), np.abs(v - np.rint(v)).min())
    return float(worst)


def _bars(kind: str, thickness_px: float) -> tuple[ObjectSpec, float]:
    """A fence or grid of bars ``thickness_px`` wide at 2 m, placed so that no bar edge projects
    within 0.005 px of a pixel centre (the first such offset on a fixed 1 mm search grid;
    float32 projection errors are ~1e-5 px)."""
    size = (1.4, 1.0, 7.3 * 2.0 / RIG.fx, thickness_px * 2.0 / RIG.fx)
    for x0, y0 in ((a * 1e-3, b * 1e-3) for a in range(40) for b in range(40)):
        margin = _margin(kind, x0, y0, size)
        if margin > 0.005:
            break
    texture = TextureSpec(kind="image", image="skimage:brick", frequency=40.0)
    return ObjectSpec(kind, Pose(translation=(x0, y0, 2.0)), size, texture, name=kind), margin


@pytest.mark.parametrize("kind", ["fence", "grid"])
@pytest.mark.parametrize("thickness_px", [1.0, 1.3, 2.0])
def test_thin_bars_depth_is_the_ray_cast_depth_at_every_pixel(renderer: Renderer, kind: str,
                                                              thickness_px: float) -> None:
    """Bars 1-2 px wide at 2 m before a wall at 4 m: no pixel may differ from the ray caster.

    No bar edge projects within 0.005 px of a pixel centre, so each pixel centre is on a bar face
    or not, unambiguously, and the rasterised depth must be the ray's first hit at every pixel
    (no edge pixel excluded)."""
    bars, margin = _bars(kind, thickness_px)
    assert margin > 0.005
    spec = SceneSpec("bars", (bars, _wall(4.0)))
    helpers = _HELPERS
    meshes = scenes.build_meshes(spec)
    for eye in ("left", "right"):
        got = renderer.render_view(spec, RIG, eye=eye).depth.astype(np.float64)
        want = helpers._raycast_depth(meshes, RIG, eye)
        on_bar = want < 3.0
        assert 0.05 < on_bar.mean() < 0.7  # the bars are there, and thin
        if kind == "fence":  # a row crosses each bar at 1 to 3 pixel centres
            runs = np.diff(on_bar[RIG.height // 2].astype(int))
            widths = np.flatnonzero(runs == -1) - np.flatnonzero(runs == 1)
            assert widths.size >= 5 and widths.min() >= 1 and widths.max() <= 3
        np.testing.assert_allclose(got, want, rtol=1e-5)


@pytest.mark.parametrize("kind", ["fence", "grid"])
def test_thin_bar_faces_match_the_closed_form(renderer: Renderer, kind: str) -> None:
    """Every pixel's disparity is the wall's, a bar front face's, or lies between the depths of
    the bars' faces (their sides, seen off-axis)."""
    bars, _ = _bars(kind, 1.5)
    t = bars.size[3]
    pair = render_pair(SceneSpec("bars", (bars, _wall(4.0))), RIG, renderer=renderer)
    fb = RIG.fx * RIG.baseline
    for d in (pair.disp_left.astype(np.float64), pair.disp_right.astype(np.float64)):
        front, wall = fb / (2.0 - t / 2), fb / 4.0
        deepest = fb / (2.0 + (3 * t / 2 if kind == "grid" else t / 2))
        on_wall = np.abs(d - wall) <= TOL_PX
        assert (on_wall | ((d >= deepest - TOL_PX) & (d <= front + TOL_PX))).all()
        assert np.isclose(d, front, atol=TOL_PX).mean() > 0.05
        assert on_wall.mean() > 0.3


def _quad_file(path: Path) -> Path:
    mesh = trimesh.Trimesh(vertices=[[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]],
                           faces=[[0, 1, 2], [0, 2, 3]], process=False)
    mesh.export(path)
    return path


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".glb"])
def test_mesh_file_plane_matches_the_closed_form(renderer: Renderer, tmp_path: Path,
                                                 suffix: str) -> None:
    path = _quad_file(tmp_path / f"quad{suffix}")
    pose = Pose(translation=(0.05, 0.02, 2.5), rotation_deg=(10.0, 25.0, 0.0))
    obj = ObjectSpec("mesh", pose, (3.0,), TextureSpec(kind="image", image="skimage:grass",
                                                       frequency=30.0), path=str(path))
    pair = render_pair(SceneSpec("quad", (obj,)), RIG, renderer=renderer)
    n = pose.rotation() @ np.array([0.0, 0.0, 1.0])
    c = float(n @ np.asarray(pose.translation))
    for disp, eye in ((pair.disp_left, "left"), (pair.disp_right, "right")):
        want = RIG.plane_disparity(n, c, eye=eye)
        assert np.isfinite(disp).all()
        assert np.abs(disp - want).max() <= TOL_PX


@pytest.mark.parametrize("make, suffix", [
    (lambda: trimesh.creation.icosphere(2, radius=1.0), ".ply"),
    (lambda: trimesh.creation.box((1.0, 1.5, 0.8)), ".glb"),
    (lambda: trimesh.creation.annulus(0.6, 1.0, 0.5), ".obj"),
])
def test_mesh_file_depth_matches_ray_casting(renderer: Renderer, tmp_path: Path, make,
                                             suffix: str) -> None:
    path = tmp_path / f"m{suffix}"
    make().export(path)
    obj = ObjectSpec("mesh", Pose(translation=(0.1, -0.05, 2.4), rotation_deg=(30.0, 40.0, 10.0)),
                     (0.5,), TextureSpec(kind="checker", frequency=12.0), path=str(path))
    spec = SceneSpec("mesh", (obj, _wall(4.0)))
    meshes = scenes.build_meshes(spec)
    helpers = _HELPERS
    for eye in ("left", "right"):
        z = renderer.render_view(spec, RIG, eye=eye).depth.astype(np.float64)
        want = helpers._raycast_depth(meshes, RIG, eye)
        inner = helpers._away_from_edges(z) & helpers._away_from_edges(want)
        assert inner.mean() > 0.7 and (want[inner] < 3.5).any()
        np.testing.assert_allclose(z[inner], want[inner], rtol=1e-5)
        assert (~np.isclose(z, want, rtol=1e-4)).mean() <= 0.01
