"""The read-only layouts of real scenes (ETH3D two-view, DrivingStereo, Middlebury 2005/2006,
scikit-image): hand-made trees read exactly, the development scenes read and scored as an
independent reading of their files scores them, and one guesser of a folder's format."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from matcher.io import encode_png, format_calib, write_pfm
from synth.cli import main
from synth.formats import get_layout, resolve_spec, spec_forms
from synth.formats.base import Layout

TINY = {"width": 64, "height": 48, "seeds": (0,)}


def _noise(shape, seed):
    return np.random.default_rng(seed).integers(0, 256, shape, np.uint8)


def _eth3d_tree(root: Path, scenes=("playground_1s", "terrace_1s"), shape=(6, 9)) -> dict:
    """ETH3D as its archives unpack: images and ground truth in sibling trees."""
    truth = {}
    for i, scene in enumerate(scenes):
        images, gt_dir = root / "two_view_training" / scene, root / "two_view_training_gt" / scene
        images.mkdir(parents=True)
        gt_dir.mkdir(parents=True)
        grey = _noise(shape, i)
        for name in ("im0.png", "im1.png"):
            (images / name).write_bytes(encode_png(np.repeat(grey[..., None], 3, axis=2)))
        (images / "calib.txt").write_text(format_calib({
            "cam0": np.array([[500.0, 0, 4], [0, 501, 3], [0, 0, 1]]), "cam1": np.eye(3),
            "doffs": 0, "baseline": 60.5, "width": shape[1], "height": shape[0],
            "ndisp": shape[1]}))
        disp = np.full(shape, 2.5 + i, np.float32)
        disp[0, :3] = np.inf
        mask = np.where(np.isfinite(disp), 255, 0).astype(np.uint8)
        mask[1, 1] = 128
        write_pfm(gt_dir / "disp0GT.pfm", disp)
        (gt_dir / "mask0nocc.png").write_bytes(encode_png(mask))
        truth[scene] = (grey, disp, mask)
    return truth


def _drivingstereo_tree(root: Path, folders=("left_images", "right_images", "disparity_maps"),
                        sequence: str | None = None, shape=(4, 10)) -> dict:
    names = ["2018-07-11-14-48-52_2018-07-11-14-50-09-070",
             "2018-07-11-14-48-52_2018-07-11-14-50-09-270"]
    truth = {}
    for i, name in enumerate(names):
        sub = f"{sequence}/" if sequence else ""
        for folder in folders:
            (root / folder / sub).mkdir(parents=True, exist_ok=True)
        left = _noise((*shape, 3), i)
        ok, jpg = cv2.imencode(".jpg", left[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 100])
        assert ok
        (root / folders[0] / f"{sub}{name}.jpg").write_bytes(jpg.tobytes())
        (root / folders[1] / f"{sub}{name}.jpg").write_bytes(jpg.tobytes())
        codes = np.zeros(shape, np.uint16)
        codes[1:, 2:] = 256 * (3 + i) + 64  # d = 3.25 + i, 0 = none
        cv2.imwrite(str(root / folders[2] / f"{sub}{name}.png"), codes)
        truth[name] = codes
    (root / "calib").mkdir(exist_ok=True)
    (root / "calib" / "2018-07-11-14-48-52.txt").write_text(
        "calib_time: 20180703\n"
        "S_rect_101: 1.000000e+3 4.000000e+2\n"  # another size first: not this one
        f"S_rect_101: {shape[1]:e} {shape[0]:e}\n"
        "P_rect_101: 1.0e+3 0 4.5e+2 0 0 1.1e+3 2.0e+2 0 0 0 1 0\n"
        "T_103: -5.4e-01 -3.0e-02 0\n")
    return truth


# --------------------------------------------------------------------------- hand-made trees
def test_eth3d_tree_reads_exactly(tmp_path):
    truth = _eth3d_tree(tmp_path / "eth3d")
    refs = resolve_spec(f"eth3d:{tmp_path / 'eth3d'}")
    assert [r.scene for r in refs] == ["eth3d:playground_1s", "eth3d:terrace_1s"]
    assert {r.kind for r in refs} == {"eth3d"} and [r.name for r in refs] == list(truth)
    for ref in refs:
        s = ref.read()
        grey, disp, mask = truth[ref.name]
        np.testing.assert_array_equal(s.left[..., 0], grey)
        np.testing.assert_array_equal(s.disp_left, disp)
        np.testing.assert_array_equal(s.mask_left, mask)
        assert s.calib == {"fx": 500.0, "fy": 501.0, "cx": 4.0, "cy": 3.0, "baseline": 0.0605}
    # the images' folder itself, and a scene folder holding images and ground truth together
    assert len(resolve_spec(f"eth3d:{tmp_path / 'eth3d' / 'two_view_training'}")) == 2
    merged = tmp_path / "merged" / "terrace_1s"
    merged.mkdir(parents=True)
    for src in (tmp_path / "eth3d" / "two_view_training" / "terrace_1s",
                tmp_path / "eth3d" / "two_view_training_gt" / "terrace_1s"):
        for f in src.iterdir():
            (merged / f.name).write_bytes(f.read_bytes())
    (one,) = resolve_spec(f"eth3d:{merged}")
    np.testing.assert_array_equal(one.read().disp_left, truth["terrace_1s"][1])


def test_drivingstereo_trees_read_exactly(tmp_path):
    for folders, sequence in ((("left_images", "right_images", "disparity_maps"), None),
                              (("train-left-image", "train-right-image", "train-disparity-map"),
                               "2018-07-11-14-48-52")):
        root = tmp_path / folders[0]
        truth = _drivingstereo_tree(root, folders, sequence)
        refs = resolve_spec(f"drivingstereo:{root}")
        assert [r.scene for r in refs] == [f"drivingstereo:{n}" for n in truth]
        for ref in refs:
            s = ref.read()
            codes = truth[ref.name]
            want = np.where(codes > 0, codes / np.float32(256), np.inf).astype(np.float32)
            np.testing.assert_array_equal(s.disp_left, want)
            assert s.left.shape == (4, 10, 3) and s.mask_left is None
            assert s.calib == pytest.approx({"fx": 1000.0, "fy": 1100.0, "cx": 450.0,
                                             "cy": 200.0, "baseline": np.hypot(0.54, 0.03)})


def test_one_guesser_tells_each_tree(tmp_path):
    _eth3d_tree(tmp_path / "eth3d")
    _drivingstereo_tree(tmp_path / "ds")
    scene = tmp_path / "mb" / "third" / "Toy"
    scene.mkdir(parents=True)
    for name in ("view1.png", "view5.png"):
        (scene / name).write_bytes(encode_png(_noise((4, 6, 3), 0)))
    (scene / "disp1.png").write_bytes(encode_png(np.full((4, 6), 9, np.uint8)))
    kitti = tmp_path / "kitti" / "training"
    for sub in ("image_2", "image_3", "disp_occ_0"):
        (kitti / sub).mkdir(parents=True)
    found = {name: Layout.detect(tmp_path / name)
             for name in ("eth3d", "ds", "mb/third", "mb/third/Toy", "kitti")}
    assert {k: v.name for k, v in found.items()} == {
        "eth3d": "eth3d", "ds": "drivingstereo", "mb/third": "middlebury",
        "mb/third/Toy": "middlebury", "kitti": "kitti"}
    assert Layout.detect(scene, among=("middlebury2014", "middlebury2005")).name == \
        "middlebury2005"
    assert Layout.detect(tmp_path) is None and Layout.detect(tmp_path / "absent") is None
    # every layout with a SPEC says so once, and the SPECs are what validate and train list
    assert list(spec_forms()) == ["middlebury", "kitti", "sceneflow", "crestereo", "fsd",
                                  "eth3d", "drivingstereo", "skimage"]


def test_a_plain_folder_of_real_scenes_is_a_training_source(tmp_path):
    from synth.jobs.train.sources import open_source

    _eth3d_tree(tmp_path / "eth3d")
    _drivingstereo_tree(tmp_path / "ds")
    for spec, n in ((f"eth3d:{tmp_path / 'eth3d'}", 2), (str(tmp_path / "eth3d"), 2),
                    (str(tmp_path / "ds"), 2), (f"drivingstereo:{tmp_path / 'ds'}", 2)):
        source = open_source(spec)
        assert source.n_train == n and source.n_val == 0, spec
        pair = source.load("train", 0)
        assert pair.visible.any() and pair.left.dtype == np.float32


def test_bad_trees_of_the_new_layouts_are_one_error_line(tmp_path):
    (tmp_path / "empty").mkdir()
    for spec, message in (
            (f"eth3d:{tmp_path / 'absent'}", "is not a folder; give the root of a tree in the "
                                             "ETH3D two-view layout"),
            (f"eth3d:{tmp_path / 'empty'}", "no sample with ground truth in"),
            (f"drivingstereo:{tmp_path / 'empty'}", "in the DrivingStereo layout")):
        result = CliRunner().invoke(main, ["validate", "ct:9", "--out", str(tmp_path / "v"),
                                           "--real", spec, "--skip-battery"])
        errors = [x for x in result.output.splitlines() if x.startswith("Error:")]
        assert result.exit_code == 2 and len(errors) == 1, result.output
        assert message in errors[0] and spec in errors[0], errors[0]
        result = CliRunner().invoke(main, ["train", spec, "--out", str(tmp_path / "m.pt"),
                                           "--steps", "1"])
        errors = [x for x in result.output.splitlines() if x.startswith("Error:")]
        assert result.exit_code == 2 and len(errors) == 1 and message in errors[0], result.output


# --------------------------------------------------------------------------- the dev scenes
def _read_pfm(path: Path) -> np.ndarray:
    """A PFM read with numpy alone (not stereoforge's reader)."""
    data = path.read_bytes()
    head, dims, scale, raw = data.split(b"\n", 3)
    width, height = (int(v) for v in dims.split())
    dtype = "<f4" if float(scale) < 0 else ">f4"
    return np.flipud(np.frombuffer(raw[:4 * width * height], dtype).reshape(height, width))


@pytest.mark.realdata
def test_the_dev_scenes_read_as_their_benchmarks_publish_them(dev_data_dir):
    eth = resolve_spec(f"eth3d:{dev_data_dir / 'eth3d'}")
    assert len(eth) == 7
    for ref in eth:
        s = ref.read()
        gt_dir = dev_data_dir / "eth3d" / "two_view_training_gt" / ref.name
        np.testing.assert_array_equal(s.disp_left, _read_pfm(gt_dir / "disp0GT.pfm"))
        np.testing.assert_array_equal(s.mask_left, cv2.imread(str(gt_dir / "mask0nocc.png"), 0))
        assert s.left.shape[:2] == s.disp_left.shape and (s.left[..., 0] == s.left[..., 2]).all()
        assert ((s.mask_left == 0) == ~np.isfinite(s.disp_left)).all()
    ds = resolve_spec(f"drivingstereo:{dev_data_dir / 'drivingstereo'}")
    assert len(ds) == 10
    for ref in ds:
        s = ref.read()
        codes = cv2.imread(str(dev_data_dir / "drivingstereo" / "disparity_maps" /
                               f"{ref.name}.png"), cv2.IMREAD_UNCHANGED)
        known = codes > 0
        np.testing.assert_array_equal(s.disp_left[known], codes[known] / np.float32(256))
        assert np.isinf(s.disp_left[~known]).all() and 0.1 < known.mean() < 0.4
        # the calibration agrees with the published depth maps: Z = fx * B / d
        depth = cv2.imread(str(dev_data_dir / "drivingstereo" / "depth_maps" / f"{ref.name}.png"),
                           cv2.IMREAD_UNCHANGED)[::2, ::2] / 256.0
        both = known & (depth > 0)
        ratio = depth[both] * s.disp_left[both] / (s.calib["fx"] * s.calib["baseline"])
        assert abs(np.median(ratio) - 1) < 0.01
    (kitti,) = resolve_spec(f"kitti:{dev_data_dir / 'kitti2015'}")
    assert kitti.scene == "kitti:training/000046" and kitti.read().disp_left.shape == (375, 1242)


@pytest.fixture(scope="module")
def dev_run(tiny_suite, dev_data_dir, tmp_path_factory, renderer):
    out = tmp_path_factory.mktemp("dev") / "v"
    result = CliRunner().invoke(main, [
        "validate", "ct:5", "--out", str(out), "--axes", "noise", "--against", "",
        "--skip-battery", "--real", f"eth3d:{dev_data_dir / 'eth3d'}",
        "--real", f"drivingstereo:{dev_data_dir / 'drivingstereo'}"])
    assert result.exit_code == 0, result.output
    return out


@pytest.mark.gl
@pytest.mark.realdata
def test_validate_scores_the_dev_scenes_as_an_independent_reading_does(dev_run, dev_data_dir):
    with open(dev_run / "results.csv") as f:
        rows = [r for r in csv.DictReader(f) if r["axis"] == "real"]
    scenes = sorted({r["scene"] for r in rows})
    assert len([s for s in scenes if s.startswith("eth3d:")]) == 7
    assert len([s for s in scenes if s.startswith("drivingstereo:")]) == 10
    checked = 0
    for r in rows:
        if r["region"] not in ("all", "nonocc"):
            continue
        kind, name = r["scene"].split(":", 1)
        if kind == "eth3d":
            gt_dir = dev_data_dir / "eth3d" / "two_view_training_gt" / name
            gt = _read_pfm(gt_dir / "disp0GT.pfm").astype(np.float64)
            mask = cv2.imread(str(gt_dir / "mask0nocc.png"), 0)
        else:
            codes = cv2.imread(str(dev_data_dir / "drivingstereo" / "disparity_maps" /
                                   f"{name}.png"), cv2.IMREAD_UNCHANGED)
            gt = np.where(codes > 0, codes / 256.0, np.inf)
            mask = None  # no occlusion mask: the nonocc region is a left-right check
        est = _read_pfm(dev_run / r["estimate"]).astype(np.float64)
        region = np.isfinite(gt)
        if r["region"] == "nonocc":
            region &= (cv2.imread(str(dev_run / r["sample"] / "mask0nocc.png"), 0) == 255
                       if mask is None else mask == 255)
        err = np.where(np.isfinite(est), np.abs(est - np.where(region, gt, 0)), np.inf)
        want = float((err[region] > 2).mean())
        assert float(r["bad_2"]) == pytest.approx(want, abs=1e-12), (r["scene"], r["region"])
        record = json.loads((dev_run / r["sample"] / "sample.json").read_text())
        assert record["kind"] == kind
        checked += 1
    assert checked == 17 * 2
