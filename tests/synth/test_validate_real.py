"""Real scenes in a validate run (--real): rows beside the axes, scored as `stereoforge eval`
scores the same estimates against the scenes' own ground-truth files."""

from __future__ import annotations

import base64
import csv
import json
import re

import numpy as np
import pytest
from click.testing import CliRunner

from matcher.io import load_middlebury_2005, read_image, write_kitti, write_middlebury, write_pfm
from matcher.regions import REGIONS, occlusion_from_disparities
from synth.cli import main

TINY = {"width": 64, "height": 48, "seeds": (0,)}


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def real_run(tiny_suite, middlebury_dir, tmp_path_factory, renderer):
    out = tmp_path_factory.mktemp("real") / "v"
    result = CliRunner().invoke(main, [
        "validate", "ct:9", "--out", str(out), "--axes", "noise", "--against", "sgbm:5",
        "--real", f"middlebury:{middlebury_dir / 'third'}", "--real", "skimage:motorcycle"])
    assert result.exit_code == 0, result.output
    return out


SCENES = [*(f"middlebury:third/{s}" for s in
            ("Baby1", "Cloth2", "Flowerpots", "Midd1", "Moebius", "Reindeer")),
          "skimage:motorcycle"]


@pytest.mark.gl
@pytest.mark.realdata
def test_real_scenes_are_rows_of_results_csv_beside_the_axes(real_run):
    rows = _rows(real_run / "results.csv")
    real = [r for r in rows if r["axis"] == "real"]
    assert [r["scene"] for r in real if r["matcher"] == "ct:9" and r["region"] == "all"] == SCENES
    assert len(real) == len(SCENES) * 2 * len(REGIONS)
    assert all(r["value"] == "" and r["seed"] == "" and r["error"] == "" for r in real)
    assert {r["scene"] for r in rows if r["axis"] == "noise"} == {"boxes"}
    moebius = real_run / "pairs/real/middlebury_third_Moebius"
    record = json.loads((moebius / "sample.json").read_text())
    assert record["divisor"] == 3.0 and record["max_disparity"] == 80
    assert record["occlusion"] == "left-right check of the left and right ground truths"
    assert record["region_pixels"]["nonocc"] < record["region_pixels"]["all"]
    page = (real_run / "report.html").read_text()
    assert "<h2>Real scenes</h2>" in page and "<td>skimage:motorcycle</td>" in page
    heatmap = base64.b64decode(re.search(r"<img class='heatmap'[^>]*src='data:image/svg\+xml;"
                                         r"base64,([^']+)'", page).group(1)).decode()
    for label in ("noise", "real (7 scenes)", *SCENES):  # the scenes beside the axes
        assert f">{label}</text>" in heatmap, label


@pytest.mark.gl
@pytest.mark.realdata
def test_real_bad_2_equals_stereoforge_eval_on_the_same_estimates(real_run, middlebury_dir,
                                                                  tmp_path):
    import skimage.data

    motorcycle_gt = tmp_path / "motorcycle.pfm"
    disp = skimage.data.stereo_motorcycle()[2]
    write_pfm(motorcycle_gt, np.where(np.isfinite(disp), disp, np.inf).astype(np.float32))
    checked = 0
    for r in _rows(real_run / "results.csv"):
        if r["axis"] != "real" or r["region"] not in ("all", "nonocc"):
            continue
        if r["scene"] == "skimage:motorcycle":
            gt = [str(motorcycle_gt)]
        else:
            scene = middlebury_dir / "third" / r["scene"].rsplit("/", 1)[1]
            gt = [str(scene / "disp1.png"), "--gt-divisor", "3"]
        result = CliRunner().invoke(main, [
            "eval", str(real_run / r["estimate"]), *gt, "--json",
            "--mask", str(real_run / r["sample"] / "mask0nocc.png")])
        assert result.exit_code == 0, result.output
        report = json.loads(result.output)
        assert 100 * float(r["bad_2"]) == pytest.approx(report[r["region"]]["bad_2"], abs=1e-9)
        checked += 1
    assert checked == len(SCENES) * 2 * 2


@pytest.mark.gl
@pytest.mark.realdata
def test_kitti_and_middeval3_layouts_use_their_own_masks(tiny_suite, middlebury_dir, tmp_path,
                                                         renderer):
    s = load_middlebury_2005(middlebury_dir / "third" / "Baby1")
    mask = occlusion_from_disparities(s.disp_left, s.disp_right)
    mask[:, :5] = np.where(mask[:, :5] == 255, 128, mask[:, :5])  # not what a check would say
    gt = np.where(mask > 0, s.disp_left, np.inf).astype(np.float32)
    write_kitti(tmp_path / "kitti", 3, left=s.left, right=s.right, disp_left=gt, mask_left=mask)
    write_middlebury(tmp_path / "MiddEval3" / "Baby1", left=s.left, right=s.right, disp_left=gt,
                     disp_right=None, mask_left=mask,
                     calib={"cam0": np.eye(3), "cam1": np.eye(3), "doffs": 0, "baseline": 1,
                            "ndisp": 64})
    out = tmp_path / "v"
    result = CliRunner().invoke(main, [
        "validate", "ct:9", "--out", str(out), "--axes", "noise", "--against", "",
        "--real", f"kitti:{tmp_path / 'kitti'}", "--real",
        f"middlebury:{tmp_path / 'MiddEval3'}", "--skip-battery"])
    assert result.exit_code == 0, result.output
    scenes = [r["scene"] for r in _rows(out / "results.csv")
              if r["axis"] == "real" and r["region"] == "all"]
    assert scenes == ["kitti:kitti/000003", "middlebury:MiddEval3/Baby1"]
    for folder in ("kitti_kitti_000003", "middlebury_MiddEval3_Baby1"):
        pair = out / "pairs" / "real" / folder
        assert json.loads((pair / "sample.json").read_text())["occlusion"] == \
            "the scene's own occlusion mask"
        assert (read_image(pair / "mask0nocc.png") == mask).all()
        assert ((read_image(pair / "mask_nonocc.png") > 0) == (mask == 255)).all()


def test_bad_real_specs_are_one_error_line(tmp_path):
    for spec, message in (
            ("flickr:cats", "expected middlebury:DIR[:DIVISOR], kitti:DIR[:FIRST-LAST], "
                            "sceneflow:DIR, crestereo:DIR, fsd:DIR, eth3d:DIR, "
                            "drivingstereo:DIR or skimage:motorcycle"),
            (f"middlebury:{tmp_path / 'absent'}", "is not a folder"),
            (f"middlebury:{tmp_path}", "no Middlebury scene in"),
            (f"kitti:{tmp_path}", "is not a KITTI 2015 training folder (no image_2/)"),
            ("skimage:astronaut", "scikit-image ships one stereo pair with ground truth: "
                                  "skimage:motorcycle")):
        result = CliRunner().invoke(main, ["validate", "ct:9", "--out", str(tmp_path / "v"),
                                           "--real", spec, "--skip-battery"])
        assert result.exit_code == 2, result.output
        errors = [x for x in result.output.splitlines() if x.startswith("Error:")]
        assert len(errors) == 1 and message in errors[0] and spec in errors[0], result.output
        assert not (tmp_path / "v").exists()


def _scene_2005(folder, codes):
    """A Middlebury 2005 scene folder: noise views and disp1.png holding ``codes``."""
    import cv2

    folder.mkdir(parents=True)
    rng = np.random.default_rng(0)
    for name in ("view1", "view5"):
        cv2.imwrite(str(folder / f"{name}.png"), rng.integers(0, 256, (*codes.shape, 3), np.uint8))
    cv2.imwrite(str(folder / "disp1.png"), codes)
    return folder


def test_the_divisor_of_a_real_scene_is_applied(tmp_path):
    from synth.validate.real import resolve_real

    codes = np.tile(np.array([0, 6, 12, 30], np.uint8), (4, 2))
    scene = _scene_2005(tmp_path / "third" / "Scene", codes)  # "third": 3 when not given
    gts = {}
    for tail in ("", ":3", ":1.5", ":6"):
        (spec,) = resolve_real([f"middlebury:{scene}{tail}"])
        gts[tail] = spec.load()[2]
    known = codes > 0
    np.testing.assert_array_equal(gts[""][known], codes[known] / np.float32(3))
    np.testing.assert_array_equal(gts[":3"], gts[""])
    np.testing.assert_array_equal(gts[":1.5"][known], codes[known] / np.float32(1.5))
    np.testing.assert_array_equal(gts[":6"][known], codes[known] / np.float32(6))
    assert np.isinf(gts[":6"][~known]).all()


def test_each_part_of_a_real_spec_has_its_own_message(tmp_path):
    from matcher.io import encode_png
    from synth.validate.real import resolve_real

    scene = _scene_2005(tmp_path / "third" / "Scene", np.full((4, 6), 9, np.uint8))
    m14 = tmp_path / "m14" / "Scene"
    m14.mkdir(parents=True)
    for name in ("im0.png", "im1.png"):
        (m14 / name).write_bytes(encode_png(np.zeros((4, 6, 3), np.uint8)))
    kitti = tmp_path / "kitti"
    (kitti / "image_2").mkdir(parents=True)
    for spec, message in (
            (f"middlebury:{scene}:-3", "DIVISOR must be a number > 0 (disparity = code / "
                                       "DIVISOR: 3 at third size), got '-3'"),
            (f"middlebury:{scene}:three", "DIVISOR must be a number > 0"),
            (f"middlebury:{scene}:nan", "DIVISOR must be a number > 0"),
            (f"middlebury:{tmp_path / 'absent'}:3", "is not a folder"),
            (f"kitti:{kitti}:a-b", "FIRST-LAST must be two frame numbers, FIRST <= LAST (e.g. "
                                   "0-9), got 'a-b'"),
            (f"kitti:{kitti}:9-2", "got '9-2'"),
            (f"middlebury:{m14}", f"{m14} has no ground truth: no disp0GT.pfm or disp0.pfm"),
            (f"middlebury:{m14}:3", "is in the 2014/MiddEval3 layout (im0.png), whose ground "
                                    "truth is in pixels: it takes no DIVISOR; drop ':3'")):
        with pytest.raises(ValueError) as info:
            resolve_real([spec])
        assert message in str(info.value) and spec in str(info.value), str(info.value)
    write_pfm(m14 / "disp0.pfm", np.ones((4, 6), np.float32))  # the 2014 archives' name
    from matcher.io import format_calib

    (m14 / "calib.txt").write_text(format_calib({"cam0": np.eye(3), "ndisp": 8}))
    (spec,) = resolve_real([f"middlebury:{m14}"])
    assert spec.kind == "middlebury2014" and spec.divisor is None


def _third_size_scene(folder):
    """A scene of the third-size release's image size (463 x 370), disparities 10 px."""
    return _scene_2005(folder, np.full((370, 463), 30, np.uint8))


@pytest.mark.parametrize("words", ["carefully", "fullsets", "halfmoon"])
def test_a_word_inside_a_folder_name_gives_no_divisor_in_any_command(tmp_path, words):
    scene = _scene_2005(tmp_path / "real" / words / "mb05", np.full((4, 6), 9, np.uint8))
    want = (f"cannot tell the disparity divisor of {scene} (no folder named third, half or "
            "full, or ThirdSize, HalfSize or FullSize); give it: middlebury:DIR:3")
    for args in (["validate", "ct:3", "--axes", "noise", "--against", "", "--skip-battery",
                  "--out", str(tmp_path / "v"), "--real", f"middlebury:{scene}"],
                 ["train", f"middlebury:{scene}", "--out", str(tmp_path / "m.pt"),
                  "--steps", "1"]):
        result = CliRunner().invoke(main, args)
        errors = [x for x in result.output.splitlines() if x.startswith("Error:")]
        assert result.exit_code == 2 and len(errors) == 1 and want in errors[0], result.output
        assert not (tmp_path / "v").exists() and not (tmp_path / "m.pt").exists()


def test_a_divisor_that_the_image_size_contradicts_is_refused(tmp_path):
    from synth.validate.real import resolve_real

    scene = _third_size_scene(tmp_path / "FullSize" / "Toy")
    with pytest.raises(ValueError, match=r"says full size \(divisor 1\) .* 463x370, the third size "
                                         r".*give it: middlebury:DIR:3"):
        resolve_real([f"middlebury:{scene}"])
    (spec,) = resolve_real([f"middlebury:{scene}:3"])  # given: the user's word
    assert spec.divisor == 3.0 and spec.note is None


def test_a_divisor_from_a_folder_far_above_the_scene_is_said(tmp_path):
    from synth.validate.real import resolve_real

    scene = _third_size_scene(tmp_path / "third" / "my" / "own" / "Toy")
    (spec,) = resolve_real([f"middlebury:{scene}"])
    assert spec.divisor == 3.0
    assert spec.note == (f"middlebury:own/Toy: divisor 3 from the folder {tmp_path / 'third'} "
                         "(3 levels above the scene)")
    (near,) = resolve_real([f"middlebury:{_third_size_scene(tmp_path / 'third' / 'Toy')}"])
    assert near.divisor == 3.0 and near.note is None
