"""The rig's height and pitch in a layout as ``[rig]`` keys: drawn per sample, recorded, refused
where the base has no floor, and the ground truth of a pitched room exact against ray casting."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import scenes
from scenes.posing import floor_height
from synth.camera.rig import StereoRig
from synth.dataset.config.parse import ConfigError, loads_config
from synth.dataset.config.sampling import draw_sample
from synth.pair import render_pair
from synth.render.renderer import Renderer

POSED = """\
seed = 4
[rig]
width = 96
height = 54
camera_height = {uniform = [0.5, 2.0]}
pitch = {uniform = [-10.0, 25.0]}
[scene]
base = "room"
"""


def _helpers():
    """tests/synth/test_ground_truth.py (its ray caster), loaded from its path."""
    spec = importlib.util.spec_from_file_location(
        "_gt_helpers_pose", Path(__file__).with_name("test_ground_truth.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_height_and_pitch_are_drawn_per_sample_and_recorded():
    cfg = loads_config(POSED)
    draws = [draw_sample(cfg, i) for i in range(6)]
    for d in draws:
        assert 0.5 <= d.params["rig.camera_height"] <= 2.0
        assert -10.0 <= d.params["rig.pitch"] <= 25.0
        level = scenes.get_preset("room", seed=d.params["scene.preset_seed"])
        # the floor turned with the rig: its point below the cameras is camera_height away
        floor = d.scene.objects[0]
        normal = floor.pose.rotation() @ np.array([0.0, 0.0, 1.0])
        distance = abs(float(normal @ np.array(floor.pose.translation)))
        assert distance == pytest.approx(d.params["rig.camera_height"], abs=1e-9)
        assert floor_height(level) != d.params["rig.camera_height"]
    assert len({d.params["rig.pitch"] for d in draws}) == 6
    # fixed values are recorded too, and a config without the keys draws what it drew
    fixed = loads_config(POSED.replace("{uniform = [-10.0, 25.0]}", "15.0"))
    assert draw_sample(fixed, 0).params["rig.pitch"] == 15.0
    plain = loads_config(POSED.replace("camera_height = {uniform = [0.5, 2.0]}\n", "")
                         .replace("pitch = {uniform = [-10.0, 25.0]}\n", ""))
    assert "rig.pitch" not in draw_sample(plain, 0).params
    assert plain.hash() != cfg.hash() != fixed.hash()


def test_camera_height_needs_a_base_with_a_floor():
    with pytest.raises(ConfigError, match=r"rig\.camera_height.*flying.*leave camera_height out"):
        loads_config(POSED.replace('"room"', '"flying"'))
    with pytest.raises(ConfigError, match=r"rig\.pitch"):
        loads_config(POSED.replace("{uniform = [-10.0, 25.0]}", "80.0"))


@pytest.mark.gl
@pytest.mark.slow
def test_a_pitched_room_has_exact_ground_truth(renderer: Renderer):
    """Depth of the pitched room = the first hit of each pixel-centre ray (embree), 1e-4
    relative away from edges; disparity fx B / Z of it."""
    helpers = _helpers()
    draw = draw_sample(loads_config(POSED), 2)
    rig = StereoRig(width=96, height=72, fx=70.0, fy=70.0, cx=47.5, cy=35.5, baseline=0.1)
    pair = render_pair(draw.scene, rig, renderer=renderer)
    meshes = scenes.build_meshes(draw.scene)
    z = renderer.render_view(draw.scene, rig, eye="left").depth.astype(np.float64)
    want = helpers._raycast_depth(meshes, rig, "left")
    inner = helpers._away_from_edges(z) & helpers._away_from_edges(want)
    assert inner.mean() > 0.6
    np.testing.assert_allclose(z[inner], want[inner], rtol=1e-4)
    np.testing.assert_allclose(pair.disp_left[inner], rig.fx * rig.baseline / want[inner],
                               rtol=1e-4)


@pytest.mark.gl
def test_only_what_a_view_sees_must_lie_within_near_and_far(renderer: Renderer):
    """An open surface may reach behind the cameras out of view (a pitched room's ceiling); one
    seen nearer than ``near``, a closed mesh reaching behind them, and an object wholly behind
    them fail, naming the object."""
    from synth.render.meshes import DepthRangeError

    rig = StereoRig(width=64, height=48, fx=60.0, fy=60.0, cx=31.5, cy=23.5, baseline=0.1)
    tex = scenes.TextureSpec(frequency=5.0, seed=1)
    wall = scenes.ObjectSpec("plane", scenes.Pose(translation=(0.05, 0.0, 5.0)), (12.0, 9.0), tex,
                             name="wall")

    def with_(obj):
        return scenes.SceneSpec("near", (obj, wall))

    # a ceiling 1 m above the cameras from 3 m behind them to 7 m ahead: out of view behind
    ceiling = scenes.ObjectSpec("plane", scenes.Pose(translation=(0.05, -1.0, 2.0),
                                                     rotation_deg=(90.0, 0.0, 0.0)),
                                (4.0, 10.0), tex, name="ceiling")
    pair = render_pair(with_(ceiling), rig, renderer=renderer)
    assert np.isfinite(pair.disp_left).all()
    # the same ceiling 0.02 m above the cameras: seen from z = 0.02 / 0.4 = 0.05 m < near
    low = scenes.ObjectSpec("plane", scenes.Pose(translation=(0.05, -0.02, 2.0),
                                                 rotation_deg=(90.0, 0.0, 0.0)),
                            (4.0, 10.0), tex, name="low")
    with pytest.raises(DepthRangeError, match=r"'low'.*in view"):
        render_pair(with_(low), rig, renderer=renderer)
    box = scenes.ObjectSpec("box", scenes.Pose(translation=(0.05, -1.5, 0.5)), (1.0, 1.0, 3.0),
                            tex, name="box")  # closed, out of view, reaching behind
    with pytest.raises(DepthRangeError, match=r"'box'.*behind the left camera"):
        render_pair(with_(box), rig, renderer=renderer)
