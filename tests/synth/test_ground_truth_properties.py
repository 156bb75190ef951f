"""Property: rendered disparity of any plane through any rig equals the closed form.

Hand-picked examples beside these: ``test_ground_truth.py`` (the plane presets
on a default and an off-centre rig, and the 3-pixel fronto plane).
"""

from __future__ import annotations

import numpy as np
import pytest
import scenes
from hypothesis import assume, given
from hypothesis import strategies as st
from scenes import ObjectSpec, Pose, SceneSpec, TextureSpec

from synth.pair import render_pair
from synth.render.renderer import Renderer
from synth.camera.rig import StereoRig

pytestmark = pytest.mark.gl

TOL_PX = 1e-3


@st.composite
def rigs(draw: st.DrawFn) -> StereoRig:
    """Small rigs (<= 64 x 48), field of view <= ~56 deg, principal point off centre."""
    w = draw(st.integers(16, 64))
    h = draw(st.integers(12, 48))
    fx = 600.0 * w / 640.0 * draw(st.floats(1.0, 3.0))
    return StereoRig(
        width=w,
        height=h,
        fx=fx,
        fy=fx * draw(st.floats(0.8, 1.25)),
        cx=(w - 1) / 2 + draw(st.floats(-0.125, 0.125)) * w,
        cy=(h - 1) / 2 + draw(st.floats(-0.125, 0.125)) * h,
        baseline=draw(st.floats(0.02, 0.5)),
    )


def _covering_plane(rig: StereoRig, z0: float, rot: tuple[float, float, float]) -> ObjectSpec:
    """A textureless plane through (B/2, 0, z0) big enough to fill both views."""
    pose = Pose(translation=(rig.baseline / 2, 0.0, z0), rotation_deg=rot)
    probe = ObjectSpec("plane", pose, (1.0, 1.0), TextureSpec(kind="constant"), name="plane")
    n, c = scenes.plane_equation(probe)
    R, T = pose.rotation(), np.asarray(pose.translation)
    corners = [(x, y) for x in (-0.5, rig.width - 0.5) for y in (-0.5, rig.height - 0.5)]
    extent = np.zeros(2)
    for ox in (0.0, rig.baseline):
        o = np.array([ox, 0.0, 0.0])
        for x, y in corners:
            r = np.array([(x - rig.cx) / rig.fx, (y - rig.cy) / rig.fy, 1.0])
            t = (c - n @ o) / (n @ r)
            assume(t > 0)
            extent = np.maximum(extent, np.abs(R[:, :2].T @ (o + t * r - T)))
    size = (float(2.2 * extent[0]), float(2.2 * extent[1]))
    return ObjectSpec("plane", pose, size, TextureSpec(kind="constant"), name="plane")


@given(
    rig=rigs(),
    z0=st.floats(1.0, 6.0),
    ax=st.floats(-35.0, 35.0),
    ay=st.floats(-40.0, 40.0),
    az=st.floats(0.0, 90.0),
)
def test_any_plane_matches_closed_form(renderer: Renderer, rig: StereoRig, z0: float, ax: float,
                                       ay: float, az: float) -> None:
    plane = _covering_plane(rig, z0, (ax, ay, az))
    mesh = scenes.build_mesh(plane)
    assume(mesh.vertices[:, 2].min() > rig.near and mesh.vertices[:, 2].max() < rig.far)
    pair = render_pair(SceneSpec("plane", (plane,)), rig, renderer=renderer)
    n, c = scenes.plane_equation(plane)
    for got, eye in ((pair.disp_left, "left"), (pair.disp_right, "right")):
        want = rig.plane_disparity(n, c, eye=eye)
        # one plane fills the view: no discontinuity, every pixel is tested
        assert np.isfinite(got).all()
        assert np.abs(got - want).max() <= TOL_PX, eye
