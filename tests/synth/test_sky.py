"""A sky at infinity: its colour depends on the direction only, its ground truth is disparity 0
(exact) with a sky mask, every layout holds it or says it cannot, and a frame of sky teaches
nothing."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import cv2
import numpy as np
import pytest

import scenes
from matcher.io import read_image, read_pfm
from scenes.layouts import outdoor
from scenes.sky import SkySpec, sky_colour
from stereoforge.errors import ParameterError
from synth.camera.rig import StereoRig
from synth.dataset.sample import teaches_nothing
from synth.pair import render_pair
from synth.render.renderer import Renderer

pytestmark = pytest.mark.gl


def _raycaster():
    """tests/synth/test_ground_truth.py's ray caster, loaded from its path (test modules are
    not importable by name under --import-mode=importlib)."""
    spec = importlib.util.spec_from_file_location(
        "_gt_helpers_sky", Path(__file__).with_name("test_ground_truth.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module._raycast_depth


_raycast_depth = _raycaster()
SKY = SkySpec(clouds=0.6, cloud_scale=0.8, seed=5)
RIG = StereoRig(width=96, height=72, fx=80.0, fy=80.0, cx=47.3, cy=40.6, baseline=0.2)


def _scene(sky: SkySpec | None = SKY) -> scenes.SceneSpec:
    """A sphere and a box against the sky, a slab of ground below the horizon."""
    tex = scenes.TextureSpec(frequency=12.0, seed=2)
    objs = (scenes.ObjectSpec("sphere", scenes.Pose(translation=(0.3, -0.2, 3.0)), (0.6,), tex),
            scenes.ObjectSpec("box", scenes.Pose(translation=(-0.9, 0.1, 5.0),
                                                 rotation_deg=(10.0, 30.0, 0.0)),
                              (0.8, 1.2, 0.6), tex),
            scenes.ObjectSpec("plane", scenes.Pose(translation=(0.1, 1.5, 6.0),
                                                   rotation_deg=(-90.0, 0.0, 0.0)),
                              (12.0, 9.0), tex))
    return scenes.SceneSpec("sky", objs, sky=sky)


def test_sky_round_trips_and_is_written_only_when_set():
    spec = _scene()
    assert scenes.loads_toml(scenes.dumps_toml(spec)) == spec
    assert scenes.loads_json(scenes.dumps_json(spec)) == spec
    assert "sky" not in scenes.scene_to_dict(_scene(None))  # other scenes keep their bytes
    with pytest.raises(ParameterError, match="SkySpec.cloud_scale"):
        SkySpec(cloud_scale=0.0)
    with pytest.raises(Exception, match="scene.sky"):
        scenes.scene_from_dict({**scenes.scene_to_dict(spec), "sky": {"cloud": 1}})


def test_sky_colour_depends_on_the_direction_only():
    rng = np.random.default_rng(0)
    d = rng.normal(size=(500, 3))
    a = sky_colour(SKY, d)
    np.testing.assert_array_equal(a, sky_colour(SKY, d * rng.uniform(0.1, 9.0, size=(500, 1))))
    assert a.dtype == np.float32 and a.shape == (500, 3) and 0 <= a.min() and a.max() <= 1
    clear = dataclasses.replace(SKY, clouds=0.0)
    up, level, down = sky_colour(clear, np.array([[0, -1.0, 0], [1.0, 0, 0], [0, 1.0, 0]]))
    np.testing.assert_allclose(up, clear.zenith, atol=1e-6)
    np.testing.assert_allclose(level, clear.horizon, atol=1e-6)
    np.testing.assert_allclose(down, clear.ground, atol=1e-6)
    # clouds change the sky above the horizon only, and another seed draws other clouds
    above = d[:, 1] < -0.3
    assert not np.array_equal(a[above], sky_colour(clear, d)[above])
    np.testing.assert_array_equal(a[d[:, 1] > 0], sky_colour(clear, d)[d[:, 1] > 0])
    assert not np.array_equal(a[above], sky_colour(dataclasses.replace(SKY, seed=6), d)[above])


@pytest.mark.slow
def test_sky_is_disparity_zero_where_no_ray_hits(renderer: Renderer):
    """Depth ``inf``, disparity exactly 0 and the sky mask exactly where a pixel-centre ray
    meets no surface (ray casting); the two views agree on the sky away from silhouettes;
    the occlusion mask codes the sky like any surface."""
    spec = _scene()
    pair = render_pair(spec, RIG, renderer=renderer)
    want = _raycast_depth(scenes.build_meshes(spec), RIG, "left")
    missed = np.isinf(want)
    assert 0.2 < missed.mean() < 0.8, "the test needs sky and objects in view"
    sky = pair.sky_left > 0
    # raster and ray disagree only on silhouette pixels, within float precision of an edge
    assert np.count_nonzero(sky != missed) <= 3
    assert np.all(pair.disp_left[sky] == 0) and np.all(np.isinf(pair.depth_left[sky]))
    assert np.all(pair.disp_left[~sky] > 0) and np.all(np.isfinite(pair.disp_left))
    want_right = _raycast_depth(scenes.build_meshes(spec), RIG, "right")
    assert np.count_nonzero((pair.disp_right == 0) != np.isinf(want_right)) <= 3
    # sky seen by both at a pixel: visible; sky where the right view sees an object: occluded
    both = sky & (pair.disp_right == 0)
    assert np.all(pair.mask_left[both] == 255)
    hidden = sky & (pair.disp_right > 0)
    assert hidden.any() and np.all(pair.mask_left[hidden] == 128)
    # the same colour in both views where both see only sky (2 px from any silhouette)
    clear = cv2.erode(both.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert clear.sum() > 500
    np.testing.assert_array_equal(pair.left[clear], pair.right[clear])
    # and the sky's colour there, within the 8-bit rounding
    rows, cols = np.nonzero(clear)
    dirs = np.stack([(cols - RIG.cx) / RIG.fx, (rows - RIG.cy) / RIG.fy, np.ones(rows.size)], 1)
    expect = 255.0 * sky_colour(SKY, dirs)
    assert np.abs(pair.left[rows, cols] - expect).max() <= 0.5 + 1e-3


@pytest.mark.slow
def test_scenes_without_sky_render_as_before(renderer: Renderer):
    """No sky: no sky mask, ``inf`` where nothing is hit, the flat background colour."""
    spec = dataclasses.replace(_scene(None), background=(0.2, 0.4, 0.6))
    pair = render_pair(spec, RIG, renderer=renderer)
    assert pair.sky_left is None
    empty = np.isinf(pair.disp_left)
    assert empty.any() and np.all(pair.mask_left[empty] == 0)
    inner = cv2.erode(empty.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    assert np.all(pair.left[inner] == (51, 102, 153))


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["middlebury", "middlebury2014", "kitti", "crestereo", "fsd",
                                 "sceneflow"])
def test_every_layout_holds_the_sky_or_says_none(renderer: Renderer, tmp_path, fmt):
    """Middlebury folders: disparity 0 and ``mask0sky.png``; SceneFlow's PFM: disparity 0 (no
    mask file in that layout); KITTI, CREStereo and FSD, whose 0 means "none": no ground truth
    there (docs/formats.md)."""
    from synth.formats import get_layout
    from synth.write.export import write_pair

    pair = render_pair(_scene(), RIG, renderer=renderer)
    sky = pair.sky_left > 0
    write_pair(pair, tmp_path, scene=_scene(), seed=0, index=0, fmt=fmt, preview=False)
    layout = get_layout(fmt)
    sample = layout.read_key(tmp_path, layout.discover(tmp_path)[0])
    if fmt.startswith("middlebury"):
        folder = tmp_path
        np.testing.assert_array_equal(read_image(folder / "mask0sky.png"), pair.sky_left)
        name = "disp0GT.pfm" if fmt == "middlebury" else "disp0.pfm"
        assert np.all(read_pfm(folder / name)[sky] == 0)
    if fmt in ("middlebury", "middlebury2014", "sceneflow"):
        np.testing.assert_array_equal(sample.disp_left, pair.disp_left)
    else:
        assert np.all(~np.isfinite(sample.disp_left[sky]))
        np.testing.assert_allclose(sample.disp_left[~sky], pair.disp_left[~sky],
                                   atol=get_layout(fmt).capacity.disp_quantum)


def test_a_frame_of_sky_teaches_nothing():
    mask = np.full((10, 10), 255, np.uint8)
    left = np.full((10, 10, 3), 120, np.uint8)
    sky = np.zeros((10, 10), np.uint8)
    sky[:9, :] = 255
    assert teaches_nothing(mask, left, sky) is None  # 90 % sky
    sky[9, :6] = 255
    assert teaches_nothing(mask, left, sky) == "no ground truth or sky"  # 96 %
    assert teaches_nothing(mask, left) is None


def test_outdoor_layout_has_a_sky_and_no_backdrop():
    for seed in range(4):
        spec = outdoor(seed)
        assert spec.sky is not None
        assert max(o.pose.translation[2] for o in spec.objects) < 95.0
    assert outdoor(0).sky != outdoor(1).sky


SKY_CONFIG = """\
seed = 2
[rig]
width = 64
height = 40
[scene]
base = "outdoor"
"""


@pytest.mark.slow
def test_a_sky_dataset_holds_its_mask_and_stats_in_folders_and_shards(tmp_path):
    """Middlebury folders get mask0sky.png and the stats its sky_fraction; WebDataset shards the
    same bytes as the ``sky`` field."""
    import json
    import tarfile

    from synth.dataset.config.parse import loads_config
    from synth.dataset.run import run_dataset

    cfg = loads_config(SKY_CONFIG)
    run_dataset(cfg, tmp_path / "mb", count=2, progress=False)
    run_dataset(cfg, tmp_path / "wds", count=2, progress=False, fmt="webdataset")
    folder = tmp_path / "mb" / "MiddEval3" / "trainingF" / "000001"
    sky = read_image(folder / "mask0sky.png")
    stats = json.loads((folder / "sample.json").read_text())["stats"]
    assert stats["sky_fraction"] == pytest.approx(np.count_nonzero(sky) / sky.size, abs=1e-6)
    assert 0 < stats["sky_fraction"] < 1
    assert np.all(read_pfm(folder / "disp0GT.pfm")[sky > 0] == 0)
    with tarfile.open(next((tmp_path / "wds").glob("shard-*.tar"))) as tar:
        member = tar.extractfile("000001.sky.png").read()
    assert member == (folder / "mask0sky.png").read_bytes()
    # the statistics table's tool reads the same figures back (docs/datasets.md)
    spec = importlib.util.spec_from_file_location(
        "_config_stats", Path(__file__).parents[2] / "tools" / "config_stats.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    got = tool.stats(tmp_path / "mb")
    fractions = [json.loads((tmp_path / "mb" / "MiddEval3" / "trainingF" / f"{i:06d}" /
                             "sample.json").read_text())["stats"]["sky_fraction"] for i in (0, 1)]
    assert got["samples"] == 2 and got["sky"] == pytest.approx(np.mean(fractions))
    assert got["low"] == 0.0 and got["invalid"] == 0.0
    assert tool.row(got).startswith("| `mb` | 2 |")
