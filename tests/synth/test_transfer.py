"""bench transfer's fair ceiling: the gap ours minus real-trained per seed, the table saying how
each learned model's box was chosen, and the checks before anything is rendered or trained."""

from __future__ import annotations

import importlib.util
import os

import pytest
from click.testing import CliRunner

if importlib.util.find_spec("torch") is None:  # the extra 'learn'
    if os.environ.get("STEREOFORGE_REQUIRE_TORCH", "") not in ("", "0"):
        raise RuntimeError("torch is not installed and STEREOFORGE_REQUIRE_TORCH=1 forbids skipping")
    pytest.skip("torch is not installed (pip install 'stereoforge[learn]')", allow_module_level=True)

from stereoforge.errors import ParameterError  # noqa: E402
from synth.cli import main  # noqa: E402
from synth.jobs.bench.transfer import _REAL, _check_aggregate, _gap, _summary  # noqa: E402


def _row(method, trained_on, seed, scene, bad3, aggregate):
    return {"method": method, "trained_on": trained_on, "seed": seed, "scene": scene,
            "aggregate": aggregate, "bad3_all": bad3, "bad2_all": bad3, "avgerr_all": 1.0,
            "bad3_nonocc": bad3, "bad2_nonocc": bad3}


def _rows():
    rows = [_row("CT-9", "", 0, s, 30.0, "") for s in ("A", "B")]
    for seed, (a, b) in {0: (20.0, 16.0), 1: (22.0, 18.0)}.items():
        rows += [_row("learned on flying", "flying", seed, "A", a, 21),
                 _row("learned on flying", "flying", seed, "B", b, 19 + 2 * seed)]
    # real-scene models: one per held-out scene and seed, scored on that scene only
    for seed, (a, b) in {0: (15.0, 17.0), 1: (16.0, 16.0)}.items():
        rows += [_row(f"learned on {_REAL}", _REAL, seed, "A", a, 5),
                 _row(f"learned on {_REAL}", _REAL, seed, "B", b, 21)]
    return rows


def test_the_gap_is_ours_minus_real_per_seed_with_its_range():
    gap = _gap(_rows(), ["flying"], [0, 1])
    assert [(g["seed"], g["ours_bad3_all"], g["real_bad3_all"], g["gap"]) for g in gap[:2]] == [
        ("0", 18.0, 16.0, 2.0), ("1", 20.0, 16.0, 4.0)]
    assert gap[2] == {"trained_on": "flying", "seed": "mean of 2", "ours_bad3_all": "",
                      "real_bad3_all": "", "gap": 3.0, "gap_min": 2.0, "gap_max": 4.0}
    assert _gap(_rows(), ["flying"], [7]) == []  # no model of that seed: no row, no made-up one


def test_the_summary_gives_the_boxes_used():
    summary = {r["method"]: r for r in _summary(_rows(), ["CT-9", "learned on flying",
                                                           f"learned on {_REAL}"])}
    assert summary["CT-9"]["aggregate"] == ""
    assert summary["learned on flying"]["aggregate"] == "19/21"
    assert summary[f"learned on {_REAL}"]["aggregate"] == "5/21"


@pytest.mark.parametrize("aggregate, scenes, ceiling, words", [
    (None, 2, True, "needs 3 real scenes"),
    (21, 1, True, "needs 2 real scenes"),
    (4, 7, True, "odd box side"),
    (0, 7, False, "odd box side"),
])
def test_bad_ceilings_fail_before_any_work(aggregate, scenes, ceiling, words):
    with pytest.raises(ParameterError, match=words):
        _check_aggregate(aggregate, scenes, ceiling)
    _check_aggregate(aggregate if aggregate not in (4, 0) else 3, 7, True)
    _check_aggregate(None, 1, False)


def test_cli_a_ceiling_without_the_middlebury_scenes_is_one_error_line(tmp_path):
    env = {"STEREOFORGE_MIDDLEBURY": str(tmp_path / "none")}
    r = CliRunner().invoke(main, ["bench", "transfer", "--configs", "flying", "--out",
                                  str(tmp_path / "o")], env=env)
    lines = r.output.strip().splitlines()
    assert r.exit_code == 2 and len(lines) == 1, r.output
    assert lines[0].startswith("Error: the in-domain ceiling needs 3 real scenes")
    assert not (tmp_path / "o").exists()
