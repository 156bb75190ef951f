"""study with MATCHER strings and kept pairs, eval-dataset on them, bench match --matcher."""

from __future__ import annotations

import csv
import os

import pytest
from click.testing import CliRunner

from synth.cli import main
from synth.jobs.bench.match import bench_match
from synth.jobs.study.run import run_study

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "user_matchers.py")
TINY = """\
name = "tiny"
seeds = [3]
max_disparity = 8
rig = {width = 64, height = 48}
scene = {kinds = ["slanted_plane"], frequencies_px = [0.05, 0.15], noise_sigma = 1.0}
match = {methods = ["ct"], windows = [5]}
"""


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.mark.gl
def test_study_with_matcher_strings_keeps_pairs_and_eval_dataset_agrees(tmp_path, renderer):
    config = tmp_path / "tiny.toml"
    config.write_text(TINY)
    plain = run_study(config, out=tmp_path / "plain", progress=False)
    out = run_study(config, out=tmp_path / "s", progress=False, keep_pairs=True,
                    matchers=[f"py:{HERE}:sad3", "ct:5", f"py:{HERE}:broken"])
    rows = _rows(out / "results.csv")
    assert [r["method"] for r in rows[:4]] == ["ct", f"py:{HERE}:sad3", "ct:5",
                                               f"py:{HERE}:broken"]
    # the built-in rows are those of the plain study, byte for byte
    plain_lines = (plain / "results.csv").read_text().splitlines()
    lines = (out / "results.csv").read_text().splitlines()
    assert [lines[0], lines[1], lines[5]] == plain_lines
    by = {(r["texture_level"], r["method"]): r for r in rows}
    assert by["0.05", "ct:5"]["pobmp"] == by["0.05", "ct"]["pobmp"]  # the same matcher
    assert by["0.05", f"py:{HERE}:broken"]["pobmp"] == "100.0"
    assert by["0.05", "ct:5"]["window"] == ""
    assert sorted(p.name for p in (out / "pairs" / "MiddEval3" / "trainingF").iterdir()) == ["000000", "000001"]
    # a kept study scores another matcher on exactly its pairs
    runner = CliRunner()
    result = runner.invoke(main, ["eval-dataset", str(out), "--matcher", "ct:5",
                                  "--out", str(tmp_path / "e")])
    assert result.exit_code == 0, result.output
    scored = {(r["index"], r["region"]): r for r in _rows(tmp_path / "e" / "results.csv")}
    assert scored["0", "nonocc"]["max_disparity"] == "8"
    assert float(scored["0", "nonocc"]["bad_2"]) >= float(scored["0", "nonocc"]["bad_4"])
    # the kept pair is the one the study's matchers saw: its PoBMP comes back exactly
    from matcher.io import read_image, read_pfm
    from matcher.metrics import evaluate

    est = read_pfm(tmp_path / "e" / "000000.pfm")
    gt = read_pfm(out / "pairs" / "MiddEval3" / "trainingF" / "000000" / "disp0GT.pfm")
    occ = read_image(out / "pairs" / "MiddEval3" / "trainingF" / "000000" / "mask0nocc.png")
    m = evaluate(est, gt, delta=3.0, region="nonocc", occlusion_mask=occ)
    assert repr(m.pobmp) == by["0.05", "ct"]["pobmp"]


@pytest.mark.gl
def test_eval_dataset_on_a_dataset_folder(tmp_path, renderer):
    from synth.dataset import run_dataset

    cfg = tmp_path / "d.toml"
    cfg.write_text("count = 2\n[rig]\nwidth = 64\nheight = 48\n")
    run_dataset(cfg, out=tmp_path / "ds", progress=False)
    result = CliRunner().invoke(main, ["eval-dataset", str(tmp_path / "ds"), "--matcher",
                                       f"py:{HERE}:broken"])
    assert result.exit_code == 0, result.output
    rows = _rows(next((tmp_path / "ds" / "eval").iterdir()) / "results.csv")
    assert len(rows) == 2 * 3 and all(r["error"] == "crashed: ZeroDivisionError: user bug" for r in rows)
    assert all(r["bad_0_5"] == "1.0" and r["coverage"] == "0.0" for r in rows if r["pixels"] != "0")


@pytest.mark.gl
def test_eval_dataset_reads_kitti_and_2014_datasets_as_their_middlebury_twin(tmp_path, renderer):
    """Same config in every layout: the same pairs, regions and estimates (KITTI's GT is the
    Middlebury one quantized to 1/256 px, the 2014 layout's the same file as disp0.pfm); KITTI's
    default search range comes from its GT."""
    import math

    import numpy as np

    from matcher.io import load_kitti_2015
    from synth.dataset import run_dataset

    cfg = tmp_path / "d.toml"
    cfg.write_text("count = 2\n[rig]\nwidth = 64\nheight = 48\n[scene]\nbase = 'boxes'\n")
    rows = {}
    for fmt in ("middlebury", "middlebury2014", "kitti"):
        run_dataset(cfg, out=tmp_path / fmt, fmt=fmt, progress=False)
        for args, key in (([], fmt), (["--max-disp", "16"], f"{fmt}-16")):
            out = tmp_path / f"eval-{key}"
            result = CliRunner().invoke(main, ["eval-dataset", str(tmp_path / fmt), "--matcher",
                                               "ct:5", "--out", str(out), *args])
            assert result.exit_code == 0, result.output
            rows[key] = _rows(out / "results.csv")
    def untimed(rows: list[dict]) -> list[dict]:
        return [{k: v for k, v in r.items() if k not in ("seconds", "mpix_disp_per_s")}
                for r in rows]

    for key, twin in (("middlebury", "middlebury2014"), ("middlebury-16", "middlebury2014-16")):
        assert untimed(rows[twin]) == untimed(rows[key])  # the 2014 layout: every score the same
        for r in rows[key]:
            assert (tmp_path / f"eval-{key}" / r["estimate"]).read_bytes() == \
                (tmp_path / f"eval-{twin}" / r["estimate"]).read_bytes()
    mid, kit = rows["middlebury-16"], rows["kitti-16"]
    assert [(r["index"], r["region"], r["pixels"]) for r in mid] == \
        [(r["index"], r["region"], r["pixels"]) for r in kit]
    assert all(int(r["pixels"]) > 0 for r in mid if r["region"] != "occluded")
    for a, b in zip(mid, kit):
        assert (tmp_path / "eval-middlebury-16" / a["estimate"]).read_bytes() == \
            (tmp_path / "eval-kitti-16" / b["estimate"]).read_bytes()
        assert abs(float(a["avgerr"]) - float(b["avgerr"])) < 0.01
    for r in rows["kitti"]:
        gt = load_kitti_2015(tmp_path / "kitti" / "training", int(r["index"])).disp_left
        vmax = math.ceil(float(gt[np.isfinite(gt)].max()))
        assert int(r["max_disparity"]) == min(16 * math.ceil((vmax + 1) / 16), 63)


def test_eval_dataset_refuses_shards(tmp_path):
    (tmp_path / "MiddEval3" / "trainingF" / "000000").mkdir(parents=True)
    (tmp_path / "MiddEval3" / "trainingF" / "000000" / "sample.json").write_text(
        '{"index": 0, "seed": 1, "dir": "000000", "params": {}, "stats": {}}')
    (tmp_path / "dataset.json").write_text('{"format": "webdataset"}')
    result = CliRunner().invoke(main, ["eval-dataset", str(tmp_path), "--matcher", "ct"])
    assert result.exit_code == 2 and "is a webdataset dataset" in result.output
    assert "Traceback" not in result.output


def test_eval_dataset_refuses_a_folder_without_samples(tmp_path):
    result = CliRunner().invoke(main, ["eval-dataset", str(tmp_path), "--matcher", "ct"])
    assert result.exit_code == 2
    assert ("no samples (MiddEval3/trainingF/NNNNNN/sample.json, 2014/NNNNNN/sample.json or "
            "training/samples/NNNNNN/sample.json)") in result.output


def test_study_refuses_a_matcher_that_does_not_resolve(tmp_path):
    config = tmp_path / "tiny.toml"
    config.write_text(TINY)
    result = CliRunner().invoke(main, ["study", str(config), "--out", str(tmp_path / "o"),
                                       "--matcher", "sad"])
    assert result.exit_code == 2 and "tried a built-in method 'sad'" in result.output


def test_bench_match_times_any_matcher_beside_opencv():
    rows = bench_match(sizes=((64, 48, 16),), repeats=1, matchers=[f"py:{HERE}:sad3", "ct:5"])
    labels = [r.label for r in rows]
    assert labels[-2:] == [f"py:{HERE}:sad3", "ct:5"] and "StereoSGBM 5" in labels
    by = {r.label: r for r in rows}
    assert by["ct:5"].accuracy == by["CT 5x5"].accuracy
    assert by[f"py:{HERE}:sad3"].accuracy > 0.9 and by[f"py:{HERE}:sad3"].seconds > 0


SWEEP = TINY.replace('frequencies_px = [0.05, 0.15]',
                     'sweep_key = "photometric.gain", sweep_values = [0.7, 1.3]')


@pytest.mark.gl
def test_study_sweeps_any_dataset_config_key(tmp_path, renderer):
    config = tmp_path / "sweep.toml"
    config.write_text(SWEEP)
    out = run_study(config, out=tmp_path / "s", progress=False)
    rows = _rows(out / "results.csv")
    assert [(r["texture_axis"], r["texture_level"]) for r in rows] == [
        ("photometric.gain", "0.7"), ("photometric.gain", "1.3")]
    assert "gain=0.7" in (out / "summary.md").read_text()
    assert sorted(p.name for p in (out / "cells" / "slanted_plane").iterdir()) == [
        "photometric.gain=0.7_c0.8_s3.json", "photometric.gain=1.3_c0.8_s3.json"]
    again = run_study(config, out=tmp_path / "t", progress=False)
    assert (again / "results.csv").read_bytes() == (out / "results.csv").read_bytes()


@pytest.mark.parametrize("scene, message", [
    ('sweep_key = "photometric.gian", sweep_values = [1.0]', "a dataset-config key"),
    ('sweep_key = "scene.occluders", sweep_values = [1.5]', "values of scene.occluders"),
    ('sweep_values = [1.0]', "sweep_key and sweep_values together"),
    ('sweep_key = "rig.baseline", sweep_values = [0.1], frequencies_px = [0.1]', "more than one"),
])
def test_a_bad_sweep_names_the_line(scene, message):
    from synth.jobs.study.run import StudyConfigError, loads_study_config

    text = TINY.replace('frequencies_px = [0.05, 0.15]', scene)
    with pytest.raises(StudyConfigError, match=message):
        loads_study_config(text, source="s.toml")
