"""Optional ground truth (synth.write.extra_ground_truth): rendered labels against per-object renders,
normals of known planes, the right view's mask, the dataset option, StereoDataset and shards
carrying it."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import scenes
from stereoforge.errors import ConfigError, ParameterError
from synth.dataset.config.parse import loads_config
from synth.dataset.run import run_dataset
from synth.formats.extras import GROUND_TRUTH
from synth.write.extra_ground_truth import (SEMANTIC_CLASSES, check_extra_kinds,
                                            render_ground_truth, right_occlusion_mask,
                                            semantic_lut)
from synth.pair import occlusion_mask, render_pair
from synth.camera.rig import StereoRig

RIG = StereoRig.default(64, 48)


def test_config_kinds_are_the_library_kinds():
    from synth.dataset.config import keys as config_keys

    assert config_keys.GROUND_TRUTH_KINDS == GROUND_TRUTH
    assert check_extra_kinds("semantic,depth") == ("depth", "semantic")
    with pytest.raises(ParameterError, match="expected distinct kinds"):
        check_extra_kinds(["depth", "depth"])
    with pytest.raises(ConfigError, match="ground_truth"):
        loads_config('ground_truth = ["depth", "albedo"]\n')


def test_a_config_without_ground_truth_keeps_its_hash():
    plain = loads_config("seed = 3\n")
    assert "ground_truth" not in plain.to_dict() and plain.ground_truth == ()
    assert loads_config('seed = 3\nground_truth = ["depth"]\n').hash() != plain.hash()


def test_right_mask_is_the_left_rule_mirrored():
    rng = np.random.default_rng(0)
    dl = rng.uniform(0, 4, (5, 12))
    dr = rng.uniform(0, 4, (5, 12))
    dl[0, :3] = np.inf
    mirrored = occlusion_mask(dr[:, ::-1], dl[:, ::-1])[:, ::-1]
    np.testing.assert_array_equal(right_occlusion_mask(dl, dr), mirrored)


@pytest.mark.gl
def test_instance_ids_name_the_object_whose_depth_the_pixel_has(renderer):
    scene = scenes.get_preset("boxes")
    pair = render_pair(scene, RIG, renderer=renderer)
    gt = render_ground_truth(pair, scene, GROUND_TRUTH, renderer=renderer)
    instance, depth = gt["instance"], gt["depth"]
    assert instance.dtype == np.uint16 and gt["semantic"].dtype == np.uint8
    np.testing.assert_array_equal(instance == 0, ~np.isfinite(depth))
    seen = set(np.unique(instance)) - {0}
    assert len(seen) >= 2  # the boxes and the background plane
    for k in seen:  # each object rendered alone has, at its pixels, the depth the pair has
        alone = dataclasses.replace(scene, objects=(scene.objects[k - 1],))
        own = renderer.render_view(alone, RIG, eye="left").depth
        np.testing.assert_array_equal(own[instance == k], depth[instance == k])
    lut = semantic_lut(scene)
    np.testing.assert_array_equal(gt["semantic"], lut[instance])
    assert [SEMANTIC_CLASSES[c] for c in lut[1:]] == [o.kind for o in scene.objects]
    n = gt["normals"]
    length = np.linalg.norm(n, axis=2)
    np.testing.assert_allclose(length[instance > 0], 1.0, atol=1e-5)
    assert not n[instance == 0].any()
    right = gt["occlusion_right"]
    np.testing.assert_array_equal(right == 0, ~np.isfinite(pair.disp_right))
    assert (right == 128).any() and (right == 255).any()


@pytest.mark.gl
def test_normals_of_a_fronto_plane_face_the_camera(renderer):
    scene = scenes.get_preset("fronto_plane")
    pair = render_pair(scene, RIG, renderer=renderer)
    n = render_ground_truth(pair, scene, ["normals"], renderer=renderer)["normals"]
    surface = np.isfinite(pair.depth_left)
    np.testing.assert_allclose(n[surface], np.broadcast_to([0.0, 0.0, -1.0], n[surface].shape),
                               atol=1e-6)


@pytest.mark.gl
def test_the_labels_pass_changes_no_byte_of_the_default_passes(renderer):
    scene = scenes.get_preset("boxes")
    before = render_pair(scene, RIG, renderer=renderer)
    renderer.render_labels(scene, RIG, eye="left")
    after = render_pair(scene, RIG, renderer=renderer)
    for name in ("left", "right", "disp_left", "disp_right", "mask_left"):
        np.testing.assert_array_equal(getattr(before, name), getattr(after, name))


CONFIG = """\
name = "gt"
seed = 4
count = 3
ground_truth = ["depth", "normals", "instance", "semantic", "occlusion_right"]

[rig]
width = 40
height = 30

[scene]
base = {choice = ["boxes", "flying"]}
"""


@pytest.mark.gl
def test_datasets_stereo_dataset_and_shards_carry_the_ground_truth(tmp_path, renderer):
    from synth import StereoDataset
    from synth.dataset.storage.integrity import verify_dataset

    cfg = loads_config(CONFIG)
    out = tmp_path / "mb"
    run_dataset(cfg, out=out, progress=False)
    assert verify_dataset(out) == []
    folder = out / "MiddEval3" / "trainingF" / "000001"
    names = {p.name for p in folder.iterdir()}
    assert {"depth0.pfm", "normals0.pfm", "instance0.png", "semantic0.png",
            "mask1nocc.png"} <= names
    item = StereoDataset(out)[1]
    assert item["depth"].shape == (30, 40) and item["normals"].shape == (30, 40, 3)
    np.testing.assert_array_equal(item["valid"], item["instance"] > 0)
    np.testing.assert_array_equal(np.isfinite(item["depth"]), item["valid"])
    assert item["occlusion_right"].dtype == np.bool_ and item["semantic"].dtype == np.uint8
    wds = tmp_path / "wds"
    run_dataset(cfg, out=wds, fmt="webdataset", shard_size=10**9, progress=False)
    import tarfile

    with tarfile.open(wds / "shard-000000.tar") as tar:
        members = {m.name: tar.extractfile(m).read() for m in tar.getmembers()}
    for source, field in (("depth0.pfm", "depth.pfm"), ("normals0.pfm", "normals.pfm"),
                          ("instance0.png", "instance.png"), ("semantic0.png", "semantic.png"),
                          ("mask1nocc.png", "mask_right.png")):
        assert members[f"000001.{field}"] == (folder / source).read_bytes()
    with pytest.raises(ParameterError, match="no place in the KITTI 2015 layout"):
        run_dataset(cfg, out=tmp_path / "kitti", fmt="kitti", progress=False)
    assert not (tmp_path / "kitti").exists()
    header = json.loads((out / "dataset.json").read_text())
    assert header["config"]["ground_truth"] == list(GROUND_TRUTH)


@pytest.mark.gl
def test_render_writes_the_requested_ground_truth(tmp_path, renderer):
    from click.testing import CliRunner

    from synth.cli import main

    def run(*args: str):
        return CliRunner().invoke(main, ["render", "boxes", "--width", "64", "--height", "48",
                                         *args])

    out = tmp_path / "boxes"
    done = run("--out", str(out), "--ground-truth", "instance,occlusion_right")
    assert done.exit_code == 0, done.output
    assert {"instance0.png", "mask1nocc.png"} <= {p.name for p in out.iterdir()}
    assert "depth0.pfm" not in {p.name for p in out.iterdir()}
    plain = tmp_path / "plain"
    assert run("--out", str(plain)).exit_code == 0
    assert not {"instance0.png", "mask1nocc.png"} & {p.name for p in plain.iterdir()}
    for name in ("im0.png", "disp0GT.pfm", "mask0nocc.png"):  # the default files unchanged
        assert (out / name).read_bytes() == (plain / name).read_bytes()
    bad = run("--out", str(tmp_path / "bad"), "--ground-truth", "albedo")
    assert bad.exit_code == 2 and bad.output.startswith("Error: --ground-truth: expected")
    kitti = run("--out", str(tmp_path / "kitti"), "--format", "kitti", "--ground-truth", "depth")
    assert kitti.exit_code == 2 and "KITTI 2015 layout" in kitti.output
    assert not (tmp_path / "bad").exists() and not (tmp_path / "kitti").exists()
