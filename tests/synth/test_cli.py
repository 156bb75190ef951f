"""The command line: each subcommand on small inputs, and its errors on bad input."""

from __future__ import annotations

import json
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from matcher.io import read_pfm, write_pfm
from scenes import ObjectSpec, Pose, SceneSpec, dump_scene, list_presets
from synth.cli import main


def _run(*args: str):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_presets_lists_every_preset_with_a_description():
    result = _run("presets")
    assert result.exit_code == 0
    lines = result.output.strip().splitlines()
    assert [line.split()[0] for line in lines] == [name for name, _ in list_presets()]
    assert all(len(line.split(maxsplit=1)) == 2 for line in lines)


def test_render_unknown_preset_lists_valid_ones(tmp_path):
    result = _run("render", "no_such_scene", "--out", tmp_path / "o")
    assert result.exit_code == 2
    assert "unknown preset 'no_such_scene'" in result.output
    assert "fronto_plane" in result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [("--baseline", "-0.1", "baseline"), ("--fx", "0", "fx")],
)
def test_render_rejects_bad_rig_and_writes_nothing(tmp_path, option, value, message):
    result = _run("render", "fronto_plane", "--out", tmp_path / "o", option, value)
    assert result.exit_code == 2
    assert message in result.output
    assert not (tmp_path / "o").exists()


def test_render_seed_with_scene_file_is_refused(tmp_path):
    path = dump_scene(
        SceneSpec(name="one", objects=(ObjectSpec(kind="plane", pose=Pose((0, 0, 3)), size=(8, 6)),)),
        tmp_path / "one.toml",
    )
    result = _run("render", path, "--seed", "3", "--out", tmp_path / "o")
    assert result.exit_code == 2 and "--seed applies to presets only" in result.output


@pytest.mark.gl
def test_render_refuses_object_behind_camera(tmp_path, renderer):
    path = dump_scene(
        SceneSpec(name="behind", objects=(ObjectSpec(kind="plane", pose=Pose((0, 0, -3)), size=(2, 2)),)),
        tmp_path / "behind.json",
    )
    result = _run("render", path, "--out", tmp_path / "o", "--width", 32, "--height", 24)
    assert result.exit_code == 2
    assert "behind the camera" in result.output or "near" in result.output
    assert not (tmp_path / "o").exists()


@pytest.mark.gl
def test_render_writes_middlebury_layout_and_refuses_non_empty_dir(tmp_path, renderer):
    out = tmp_path / "sp"
    args = ("render", "slanted_plane", "--out", out, "--width", 64, "--height", 48, "--seed", 2)
    result = _run(*args)
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in out.iterdir())
    assert names == ["calib.txt", "disp0GT.pfm", "disp1GT.pfm", "im0.png", "im1.png", "im1E.png",
                     "im1L.png", "mask0nocc.png", "preview.png", "scene.json"]
    record = json.loads((out / "scene.json").read_text())
    assert record["seed"] == 2 and record["rig"]["width"] == 64
    assert record["scene"]["name"] == "slanted_plane"
    disp = read_pfm(out / "disp0GT.pfm")
    assert disp.shape == (48, 64) and np.isfinite(disp).all()

    again = _run(*args)
    assert again.exit_code == 2 and "--overwrite" in again.output
    assert _run(*args, "--overwrite").exit_code == 0


@pytest.mark.gl
def test_render_middlebury_2014_layout_renames_only_the_ground_truth(tmp_path, renderer):
    args = ("render", "boxes", "--width", 64, "--height", 48)
    assert _run(*args, "--out", tmp_path / "mv3").exit_code == 0
    result = _run(*args, "--out", tmp_path / "2014", "--format", "middlebury2014")
    assert result.exit_code == 0, result.output
    renamed = {"disp0GT.pfm": "disp0.pfm", "disp1GT.pfm": "disp1.pfm"}
    mv3 = {renamed.get(p.name, p.name): p.read_bytes() for p in (tmp_path / "mv3").iterdir()}
    ours = {p.name: p.read_bytes() for p in (tmp_path / "2014").iterdir()}
    assert json.loads(ours.pop("scene.json")) == {**json.loads(mv3.pop("scene.json")),
                                                  "format": "middlebury2014"}
    assert ours == mv3


@pytest.mark.gl
def test_render_kitti_layout(tmp_path, renderer):
    out = tmp_path / "k"
    result = _run("render", "boxes", "--out", out, "--format", "kitti", "--width", 64, "--height", 48)
    assert result.exit_code == 0, result.output
    for sub in ("image_2", "image_3", "disp_occ_0", "disp_noc_0", "obj_map"):
        assert (out / "training" / sub / "000000_10.png").is_file()
    assert (out / "training" / "calib_cam_to_cam" / "000000.txt").is_file()
    occ = cv2.imread(str(out / "training" / "disp_occ_0" / "000000_10.png"), cv2.IMREAD_UNCHANGED)
    assert occ.dtype == np.uint16 and occ.max() > 0
    # boxes: four boxes (foreground) before a wall (background, a plane object)
    obj = cv2.imread(str(out / "training" / "obj_map" / "000000_10.png"), cv2.IMREAD_UNCHANGED)
    assert obj.dtype == np.uint8 and set(np.unique(obj)) == {0, 1}
    assert 0.05 < float(np.mean(obj == 1)) < 0.9


def _shifted_pair(tmp_path: Path, shift: int = 4):
    rng = np.random.default_rng(0)
    strip = rng.integers(0, 256, size=(40, 80 + shift), dtype=np.uint8)
    left, right = strip[:, :80], strip[:, shift : shift + 80]
    cv2.imwrite(str(tmp_path / "l.png"), left)
    cv2.imwrite(str(tmp_path / "r.png"), right)
    gt = np.full((40, 80), float(shift), dtype=np.float32)
    gt[:, :shift] = np.inf
    write_pfm(tmp_path / "gt.pfm", gt)
    return tmp_path / "l.png", tmp_path / "r.png", tmp_path / "gt.pfm"


def test_match_then_eval_recovers_a_shift(tmp_path):
    left, right, gt = _shifted_pair(tmp_path)
    out = tmp_path / "d.pfm"
    result = _run("match", left, right, "--method", "ct", "--window", 5, "--max-disp", 16, "--out", out)
    assert result.exit_code == 0, result.output
    ev = _run("eval", out, gt, "--json")
    assert ev.exit_code == 0, ev.output
    report = json.loads(ev.output)
    # the interior is exact; the columns near the left border may be wrong but few
    assert report["all"]["pobmp"] < 5.0
    assert report["all"]["n_pixels"] == 40 * 76


def test_match_rejects_even_window(tmp_path):
    left, right, _ = _shifted_pair(tmp_path)
    result = _run("match", left, right, "--window", 4, "--out", tmp_path / "d.pfm")
    assert result.exit_code == 2 and "window" in result.output and not (tmp_path / "d.pfm").exists()


def test_match_rejects_unreadable_file(tmp_path):
    (tmp_path / "bad.png").write_bytes(b"not a png")
    result = _run("match", tmp_path / "bad.png", tmp_path / "bad.png", "--out", tmp_path / "d.pfm")
    assert result.exit_code == 2 and "bad.png" in result.output


def test_eval_rejects_corrupt_pfm(tmp_path):
    (tmp_path / "x.pfm").write_bytes(b"Pf\n4 4\n-1\n\x00\x00")
    _, _, gt = _shifted_pair(tmp_path)
    result = _run("eval", tmp_path / "x.pfm", gt)
    assert result.exit_code == 2 and "x.pfm" in result.output


@pytest.mark.gl
def test_render_from_manifest_respects_overwrite(tmp_path, renderer):
    from synth.dataset.run import run_dataset

    run_dataset("planes", out=tmp_path / "ds", count=1, progress=False)
    out = tmp_path / "one"
    out.mkdir()
    (out / "other.txt").write_text("x")
    refused = _run("render", "--from-manifest", tmp_path / "ds", 0, "--out", out)
    assert refused.exit_code == 2 and "--overwrite" in refused.output
    done = _run("render", "--from-manifest", tmp_path / "ds", 0, "--out", out, "--overwrite")
    assert done.exit_code == 0, done.output
    assert (out / "im0.png").read_bytes() == (tmp_path / "ds" / "MiddEval3" / "trainingF" / "000000" / "im0.png").read_bytes()


def test_match_reports_the_warm_time_and_the_first_call_apart(tmp_path):
    from synth.jobs.bench.timing import first_and_warm

    golden = Path(__file__).resolve().parents[2] / "golden" / "boxes"
    result = _run("match", golden / "im0.png", golden / "im1.png", "--method", "ct", "--window", "5",
                  "--max-disp", "24", "--out", tmp_path / "d.pfm")
    assert result.exit_code == 0, result.output
    assert re.search(r"ct 5x5 D=24: [0-9.]+ ms warm \(first call [0-9]+ ms, ", result.output)
    calls = []
    timed = first_and_warm(lambda: calls.append(1) or len(calls))
    assert calls == [1, 1] and timed.result == 2 and timed.compile_s == 0.0


@pytest.mark.slow
def test_match_says_when_it_compiles_kernels(tmp_path):
    """A fresh numba cache (a new install): the first call's compile time is named, once."""
    import os
    import subprocess
    import sys

    golden = Path(__file__).resolve().parents[2] / "golden" / "boxes"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    args = [str(golden / "im0.png"), str(golden / "im1.png"), "--method", "sct", "--window", "5",
            "--max-disp", "16", "--out", str(tmp_path / "d.pfm")]
    code = "import sys; from synth.cli import main; main(sys.argv[1:])"
    runs = [subprocess.run([sys.executable, "-c", code, "match", *args], env=env,
                           capture_output=True, text=True, check=True).stdout for _ in range(2)]
    assert re.search(r"ms of it compiling kernels once, cached for later runs", runs[0]), runs[0]
    assert "kernels loaded from numba's cache" in runs[1], runs[1]


def test_eval_benchmark_labels_each_convention(tmp_path):
    gt = np.full((8, 12), 10.0, np.float32)
    est = gt.copy()
    est[:, :3] = np.inf  # holes: the devkit interpolates them, ETH3D counts them as coverage
    est[0, 5] = 20.0
    write_pfm(tmp_path / "gt.pfm", gt)
    write_pfm(tmp_path / "est.pfm", est)
    result = _run("eval", tmp_path / "est.pfm", tmp_path / "gt.pfm", "--benchmark", "all", "--json")
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    assert sorted(report) == ["eth3d all", "kitti occ", "middlebury all"]
    assert "devkit" in report["kitti occ"]["convention"]
    assert report["kitti occ"]["all"] == pytest.approx(100 / 96)  # holes filled with 10: one outlier
    assert report["kitti occ"]["density"] == pytest.approx(75.0)
    assert report["middlebury all"]["invalid"] == pytest.approx(25.0)
    assert report["eth3d all"]["coverage"] == pytest.approx(75.0)
    assert report["eth3d all"]["bad_2"] == pytest.approx(100 / 72)
    table = _run("eval", tmp_path / "est.pfm", tmp_path / "gt.pfm", "--benchmark", "kitti")
    assert table.exit_code == 0 and table.output.startswith("kitti occ  (KITTI 2015 devkit")


@pytest.mark.gl
def test_render_writes_the_exposure_and_lighting_variants(tmp_path, renderer):
    out = tmp_path / "v"
    result = _run("render", "boxes", "--out", out, "--width", 64, "--height", 48,
                  "--exposure-variant", 0.5, "--lighting-variant", 40)
    assert result.exit_code == 0, result.output
    for name in ("im1E.png", "im1L.png"):
        assert (out / name).read_bytes() != (out / "im1.png").read_bytes()
    render = json.loads((out / "scene.json").read_text())["render"]
    assert render["exposure_variant"] == 0.5 and "light" in render["lighting_variant"]
    for flag, value, needle in (("--exposure-variant", 0, "exposure: expected a finite number"),
                                ("--lighting-variant", 200, "lighting variant (degrees)")):
        bad = _run("render", "boxes", "--out", tmp_path / "bad", "--width", 64, "--height", 48,
                   flag, value)
        assert bad.exit_code != 0 and needle in bad.output
        assert bad.output.count("Error:") == 1 and "Traceback" not in bad.output
        assert not (tmp_path / "bad").exists()
