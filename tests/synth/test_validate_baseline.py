"""Baselines: --baseline DIR, --fail-on regression[:POINTS] and --compare OLD NEW.

The planted regression is ``user_matchers.ct9_worse_under_noise``: CT-9, but on pairs whose
left view carries sensor noise (estimated from the image itself) 8 % of the estimates are moved
half the search range away. Against a run of CT-9 it must fail ``--fail-on regression`` on the
noise axis and nowhere else; CT-9 against its own earlier run must pass with no difference.
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil

import pytest
from click.testing import CliRunner

from synth.cli import main

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "user_matchers.py")
PLANTED = f"py:{HERE}:ct9_worse_under_noise"
TINY = {"width": 64, "height": 48, "seeds": (0, 1, 2)}
AXES = "noise,blur,gain,occluders"


def _validate(*args):
    return CliRunner().invoke(main, ["validate", *map(str, args)])


def _differences(folder):
    with open(folder / "differences.csv") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def ct9_run(tiny_suite, tmp_path_factory, renderer):
    """CT-9 against SGBM-5 on four axes of the tiny suite (no battery: the report is tested
    elsewhere)."""
    out = tmp_path_factory.mktemp("baseline") / "ct9"
    result = _validate("ct:9", "--out", out, "--axes", AXES, "--against", "sgbm:5",
                       "--skip-battery")
    assert result.exit_code == 0, result.output
    return out


@pytest.mark.gl
def test_a_finished_run_records_its_pairs_and_matchers(ct9_run):
    doc = json.loads((ct9_run / "run.json").read_text())
    assert doc["matcher"] == "ct:9" and doc["references"] == ["sgbm:5"]
    assert doc["suite"] == "quick" and doc["axes"] == AXES.split(",") and doc["real"] == []
    assert len(doc["pairs"]) == 4 * 3 * 3 and all(len(d) == 64 for d in doc["pairs"].values())
    assert set(doc["estimates"]) == {"ct:9", "sgbm:5"}
    rows = _differences(ct9_run)
    assert {r["reference"] for r in rows} == {"sgbm:5"} and len(rows) >= 4 * 3


@pytest.mark.gl
def test_a_planted_regression_fails_and_names_its_axis(ct9_run, tmp_path):
    out = tmp_path / "planted"
    result = _validate(PLANTED, "--out", out, "--axes", AXES, "--against", "sgbm:5",
                       "--baseline", ct9_run, "--fail-on", "regression", "--skip-battery")
    assert result.exit_code == 1, result.output
    assert "Traceback" not in result.output
    # every pair came from the baseline, and so did SGBM's estimates: only the matcher ran
    assert "pairs: 0 rendered, 36 reused (36 from the baseline); estimates: 36 computed, " \
           "36 reused" in result.output
    line = next(x for x in result.output.splitlines() if x.startswith("regression against"))
    assert "the baseline ct:9" in line and str(ct9_run) in line
    named = set(re.findall(r"(\w+) / \w+ \+", line))
    assert named == {"noise"}, line
    rows = {(r["reference"], r["axis"], r["region"]): r for r in _differences(out)}
    noise = rows["baseline ct:9", "noise", "all"]
    assert noise["verdict"] == "worse" and float(noise["mean"]) > 2.0
    for axis in ("blur", "gain", "occluders"):  # CT-9's own answers there: no difference
        assert float(rows["baseline ct:9", axis, "all"]["mean"]) == 0.0
    # a threshold above the regression passes
    again = _validate(PLANTED, "--out", out, "--axes", AXES, "--against", "sgbm:5",
                      "--baseline", ct9_run, "--fail-on", "regression:50", "--skip-battery")
    assert again.exit_code == 0, again.output
    assert "pairs: 0 rendered, 36 reused; estimates: 0 computed, 72 reused" in again.output


@pytest.mark.gl
def test_ct9_against_its_own_earlier_run_passes_with_no_difference(ct9_run, tmp_path):
    out = tmp_path / "again"
    result = _validate("ct:9", "--out", out, "--axes", AXES, "--against", "sgbm:5",
                       "--baseline", ct9_run, "--fail-on", "regression", "--skip-battery")
    assert result.exit_code == 0, result.output
    mine = [r for r in _differences(out) if r["reference"] == "baseline ct:9"]
    assert mine and {float(r["mean"]) for r in mine} == {0.0}
    assert {r["verdict"] for r in mine} == {"no clear difference"}


@pytest.mark.gl
def test_compare_makes_the_report_of_two_finished_runs(ct9_run, tmp_path):
    planted = tmp_path / "planted"
    assert _validate(PLANTED, "--out", planted, "--axes", AXES, "--against", "sgbm:5",
                     "--baseline", ct9_run).exit_code == 0
    out = tmp_path / "cmp"
    result = _validate("--compare", ct9_run, planted, "--out", out)
    assert result.exit_code == 0, result.output
    page = (out / "report.html").read_text()
    assert "against baseline ct:9" in page and "Most worse than baseline ct:9: <b>noise</b>" in page
    assert (out / "differences.csv").read_bytes() == (planted / "differences.csv").read_bytes()
    assert sorted(p.name for p in out.iterdir()) == ["differences.csv", "report.html"]
    failed = _validate("--compare", ct9_run, planted, "--out", out, "--fail-on", "regression")
    assert failed.exit_code == 1 and "noise / all +" in failed.output


@pytest.mark.gl
def test_a_baseline_of_another_suite_axis_set_or_pairs_is_refused(ct9_run, tmp_path):
    def error(*args):
        result = _validate("ct:9", "--out", tmp_path / "x", "--skip-battery", *args)
        assert result.exit_code == 2, result.output
        lines = [x for x in result.output.splitlines() if x.startswith("Error:")]
        assert len(lines) == 1 and "Traceback" not in result.output, result.output
        return lines[0]

    assert "made with --suite quick, this run uses --suite full" in error(
        "--suite", "full", "--baseline", ct9_run, "--axes", AXES)
    assert "other axes: only in the baseline: gain, occluders; only in this run: none; pass " \
           f"--axes {AXES} to compare" in error("--baseline", ct9_run, "--axes", "noise,blur")
    assert "other real scenes: only in the baseline: none; only in this run: " \
           "skimage:motorcycle" in error("--baseline", ct9_run, "--axes", AXES, "--real",
                                         "skimage:motorcycle")
    assert "not a finished validate folder (no run.json)" in error("--baseline", tmp_path,
                                                                   "--axes", AXES)
    # a pair that is not the baseline's: other pixels in one image
    damaged = tmp_path / "damaged"
    shutil.copytree(ct9_run, damaged)
    doc = json.loads((damaged / "run.json").read_text())
    rel = "pairs/noise/4_s1"
    doc["pairs"][rel] = "0" * 64
    (damaged / "run.json").write_text(json.dumps(doc))
    (tmp_path / "x").mkdir()
    shutil.copytree(ct9_run / "pairs", tmp_path / "x" / "pairs")
    from matcher.io import encode_png, read_image

    image = read_image(damaged / rel / "im0.png")
    image[0, 0] ^= 1
    (damaged / rel / "im0.png").write_bytes(encode_png(image))
    message = error("--baseline", damaged, "--axes", AXES)
    assert f"pair {rel} is not the same: im0.png: 1 of" in message
    assert error("--baseline", ct9_run, "--axes", AXES, "--fail-on", "regresion") == (
        "Error: Invalid value for '--fail-on': expected properties, regression or "
        "regression:POINTS (POINTS a number of bad-2 points >= 0, e.g. regression:2), got "
        "'regresion'")
    assert "give --baseline DIR" in error("--axes", AXES, "--fail-on", "regression")
    assert "leave out MATCHER" in CliRunner().invoke(
        main, ["validate", "ct:9", "--compare", str(ct9_run), str(ct9_run), "--out",
               str(tmp_path / "c")]).output
    assert "--suite belongs to a run" in CliRunner().invoke(
        main, ["validate", "--compare", str(ct9_run), str(ct9_run), "--out",
               str(tmp_path / "c"), "--suite", "full"]).output


def test_a_regression_is_worse_by_more_than_points_not_by_exactly_points():
    from synth.validate.differences import regressions

    row = {"reference": "baseline ct:9", "axis": "noise", "scene": "", "region": "all",
           "verdict": "worse", "mean": 2.0, "half_width": 0.5}
    assert regressions([row], "baseline ct:9", 2.0) == []  # exactly the threshold: no failure
    assert regressions([row], "baseline ct:9", 1.999) == [row]
    assert regressions([{**row, "verdict": "no clear difference"}], "baseline ct:9", 1.0) == []


def _damaged(ct9_run, tmp_path, name, change):
    folder = tmp_path / name
    shutil.copytree(ct9_run, folder)
    path = folder / "results.csv"
    path.write_bytes(change(path.read_bytes()))
    return folder


@pytest.mark.gl
@pytest.mark.parametrize("name, change, words", [
    ("empty", lambda b: b"", "results.csv is empty"),
    ("header_only", lambda b: b.split(b"\n")[0] + b"\n", "holds a header and no rows"),
    ("truncated", lambda b: b[:len(b) // 2], "is cut short (its last line is incomplete)"),
    ("short_line", lambda b: b"\n".join(line.rsplit(b",", 3)[0] if i == 5 else line
                                        for i, line in enumerate(b.split(b"\n"))),
     "line 6 has 18 of 21 fields"),
    ("missing_row", lambda b: b"\n".join(line for i, line in enumerate(b.split(b"\n"))
                                         if i != 7), "has no row of ct:9 on pairs/"),
    ("other_columns", lambda b: b.replace(b"bad_2", b"bad_3", 1), "has no column bad_2"),
])
def test_a_baseline_needs_a_complete_results_csv(ct9_run, tmp_path, name, change, words):
    from synth.validate.baseline import load_run
    from stereoforge.errors import DatasetError

    folder = _damaged(ct9_run, tmp_path, name, change)
    with pytest.raises(DatasetError) as info:
        load_run(folder)
    text = str(info.value)
    assert words in text and f"--baseline {folder}: results.csv" in text and "\n" not in text
    assert "run `stereoforge validate" in text


@pytest.mark.gl
def test_a_truncated_baseline_fails_the_gate_instead_of_passing_it(ct9_run, tmp_path):
    folder = _damaged(ct9_run, tmp_path, "cut", lambda b: b[:len(b) // 3])
    result = _validate(PLANTED, "--out", tmp_path / "new", "--axes", AXES, "--against",
                       "sgbm:5", "--baseline", folder, "--fail-on", "regression",
                       "--skip-battery")
    assert result.exit_code == 2, result.output
    errors = [x for x in result.output.splitlines() if x.startswith("Error:")]
    assert len(errors) == 1 and "is cut short" in errors[0]
    assert not (tmp_path / "new").exists()


@pytest.mark.gl
def test_a_baseline_lends_its_real_scenes(tiny_suite, tmp_path, renderer):
    base = tmp_path / "base"
    first = _validate("ct:9", "--out", base, "--axes", "noise", "--against", "",
                      "--real", "skimage:motorcycle", "--skip-battery")
    assert first.exit_code == 0, first.output
    out = tmp_path / "new"
    result = _validate("ct:9", "--out", out, "--axes", "noise", "--against", "",
                       "--baseline", base, "--skip-battery")
    assert result.exit_code == 0, result.output
    assert "real scenes compared with the baseline (the baseline's): skimage:motorcycle" \
        in result.output
    with open(out / "results.csv") as f:
        real = {r["scene"] for r in csv.DictReader(f) if r["axis"] == "real"}
    assert real == {"skimage:motorcycle"}
    assert json.loads((out / "run.json").read_text())["real"] == ["skimage:motorcycle"]
    rows = [r for r in _differences(out) if r["reference"] == "baseline ct:9"
            and r["scene"] == "skimage:motorcycle"]
    assert rows and {float(r["mean"]) for r in rows} == {0.0}
    # an explicit other set is still refused, the difference named
    other = tmp_path / "third" / "Scene"
    other.mkdir(parents=True)
    import cv2
    import numpy as np

    for name in ("view1", "view5"):
        cv2.imwrite(str(other / f"{name}.png"), np.zeros((8, 12, 3), np.uint8))
    cv2.imwrite(str(other / "disp1.png"), np.full((8, 12), 6, np.uint8))
    refused = _validate("ct:9", "--out", tmp_path / "x", "--axes", "noise", "--against", "",
                        "--baseline", base, "--real", f"middlebury:{other}", "--skip-battery")
    assert refused.exit_code == 2, refused.output
    assert "other real scenes: only in the baseline: skimage:motorcycle; only in this run: " \
           "middlebury:third/Scene; leave out --real to take the baseline's " \
           "(skimage:motorcycle)" in refused.output
