"""The property battery: good matchers pass the required properties, broken ones fail the right ones."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from matcher import match
from matcher.io import read_image
from stereoforge.errors import ParameterError
from synth.validate.properties import MAX_TIMEOUTS, PROPERTIES, run_battery

REQUIRED = {p.name for p in PROPERTIES if p.required}
ACCURACY = {"integer_shift", "subpixel_shift", "planar_warp"}


def ct9(left, right, *, max_disparity):
    return match(left, right, method="ct", window=9, max_disparity=max_disparity).disparity


def sgbm(left, right, *, max_disparity):
    return match(left, right, method="sgbm", window=5, max_disparity=max_disparity,
                 subpixel=True).disparity


def _failed(entries: list[dict]) -> set[str]:
    return {e["name"] for e in entries if not e["passed"]}


@pytest.mark.parametrize("matcher", [ct9, sgbm], ids=["ct9", "sgbm5"])
def test_good_matchers_pass_every_required_property(matcher, tmp_path: Path) -> None:
    entries = run_battery(matcher, tmp_path, name=matcher.__name__)
    assert [e["name"] for e in entries] == [p.name for p in PROPERTIES]
    assert not _failed(entries) & REQUIRED, [e["explanation"] for e in entries if not e["passed"]]
    assert all(e["counterexample"] is None for e in entries if e["passed"])
    assert not (tmp_path / "properties").exists() or not any((tmp_path / "properties").iterdir())


def test_zeros_fail_accuracy_but_not_consistency(tmp_path: Path) -> None:
    entries = run_battery(lambda left, right, *, max_disparity: np.zeros(left.shape[:2]), tmp_path)
    failed = _failed(entries)
    assert ACCURACY <= failed
    assert not failed & {"output_shape_dtype", "invalid_marking", "identical_views_zero",
                         "mirror_symmetry", "translation_equivariance", "left_border"}
    shift = next(e for e in entries if e["name"] == "integer_shift")
    # shrunk: the smallest failing shift is 1 px, on the smallest image
    assert shift["explanation"].startswith("bad-0.5 100.0 % on a 1 px shift of noise, 48 x 48")


def test_an_answer_off_by_one_fails_shifts_identity_and_border(tmp_path: Path) -> None:
    def plus_one(left, right, *, max_disparity):
        return ct9(left, right, max_disparity=max_disparity) + 1.0

    failed = _failed(run_battery(plus_one, tmp_path))
    assert {"integer_shift", "identical_views_zero", "left_border"} <= failed
    assert "output_shape_dtype" not in failed and "mirror_symmetry" not in failed


def test_a_position_dependent_answer_fails_mirror_symmetry(tmp_path: Path) -> None:
    def lopsided(left, right, *, max_disparity):
        d = ct9(left, right, max_disparity=max_disparity)
        d[:, d.shape[1] // 2:] += 3.0
        return d

    failed = _failed(run_battery(lopsided, tmp_path))
    assert "mirror_symmetry" in failed and "output_shape_dtype" not in failed


def test_minus_one_for_no_estimate_fails_invalid_marking(tmp_path: Path) -> None:
    def opencv_style(left, right, *, max_disparity):
        d = ct9(left, right, max_disparity=max_disparity)
        d[:, :max_disparity] = -1.0  # what StereoSGBM's raw output / 16 holds there
        return d

    entries = run_battery(opencv_style, tmp_path)
    marking = next(e for e in entries if e["name"] == "invalid_marking")
    assert not marking["passed"] and "(e.g. -1)" in marking["explanation"]


def test_wrong_shape_and_crashes_fail_with_what_happened(tmp_path: Path) -> None:
    entries = run_battery(lambda left, right, *, max_disparity: np.zeros((3, 4)), tmp_path / "a")
    contract = entries[0]
    assert contract["name"] == "output_shape_dtype" and not contract["passed"]
    assert contract["explanation"].startswith("returned shape (3, 4), expected (24, 24)")

    def crash(left, right, *, max_disparity):
        raise RuntimeError("boom\nsecond line")

    entries = run_battery(crash, tmp_path / "b")
    assert len(entries) == len(PROPERTIES) and not any(e["passed"] for e in entries)
    assert all(e["explanation"].startswith("raised RuntimeError: boom on ") for e in entries)
    assert entries[0]["counterexample"] == ["properties/output_shape_dtype/left.png",
                                            "properties/output_shape_dtype/right.png"]


def test_counterexamples_are_pngs_of_the_shrunk_case_and_the_run_is_deterministic(
        tmp_path: Path) -> None:
    def zeros(left, right, *, max_disparity):
        return np.zeros(left.shape[:2], np.float32)

    first = run_battery(zeros, tmp_path / "a", suite="quick", name="zeros")
    run_battery(zeros, tmp_path / "b", suite="quick", name="zeros")
    shift = next(e for e in first if e["name"] == "integer_shift")
    assert shift["counterexample"] == [f"properties/integer_shift/{n}.png"
                                       for n in ("left", "right", "expected", "answer")]
    images = [read_image(tmp_path / "a" / rel) for rel in shift["counterexample"]]
    assert {img.shape[:2] for img in images} == {(48, 48)}
    a, b = (sorted(p.relative_to(d) for p in d.rglob("*")) for d in (tmp_path / "a", tmp_path / "b"))
    assert a == b
    for rel in a:
        if (tmp_path / "a" / rel).is_file():
            assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes(), rel
    doc = json.loads((tmp_path / "a" / "properties.json").read_text())
    assert doc["matcher"] == "zeros" and doc["suite"] == "quick" and doc["properties"] == first


def test_a_rerun_that_passes_removes_the_old_counterexample(tmp_path: Path) -> None:
    run_battery(lambda left, right, *, max_disparity: np.zeros(left.shape[:2]), tmp_path)
    assert (tmp_path / "properties" / "integer_shift" / "left.png").is_file()
    run_battery(ct9, tmp_path)
    assert not (tmp_path / "properties" / "integer_shift").exists()


def test_unknown_suite_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ParameterError, match="suite: expected one of"):
        run_battery(ct9, tmp_path, suite="huge")


# --------------------------------------------------------------------------- docs/validate.md
_EXAMPLES = Path(__file__).resolve().parents[2] / "docs" / "examples"


def _example(file: str, function: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"docs_example_{Path(file).stem}", _EXAMPLES / file)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return getattr(module, function)


def test_the_tutorials_sad_matcher_runs_and_passes_what_the_tutorial_says(tmp_path: Path) -> None:
    source = (_EXAMPLES / "sad_matcher.py").read_text()
    assert len([ln for ln in source.splitlines() if ln.strip()]) <= 20
    failed = _failed(run_battery(_example("sad_matcher.py", "sad"), tmp_path, name="sad"))
    assert failed == {"gain_bias_robustness", "monotone_grey_map_robustness"}


def test_the_tutorials_stereobm_fails_invalid_marking_until_fixed(tmp_path: Path) -> None:
    raw = run_battery(_example("opencv_bm.py", "stereo_bm_raw"), tmp_path / "raw")
    assert _failed(raw) == {"invalid_marking"}
    assert not _failed(run_battery(_example("opencv_bm.py", "stereo_bm"), tmp_path / "fixed"))


def test_the_tutorial_quotes_the_example_files_as_they_are() -> None:
    page = (_EXAMPLES.parent / "validate.md").read_text()
    sad = (_EXAMPLES / "sad_matcher.py").read_text()
    assert sad[sad.index("import numpy"):] in page
    bm = (_EXAMPLES / "opencv_bm.py").read_text()
    body = bm[bm.index("def stereo_bm_raw"):bm.index("\n\n\ndef stereo_bm(")]
    quoted = "\n".join(ln for ln in body.splitlines() if not ln.strip().startswith('"""'))
    assert quoted in page


def test_an_adapters_failure_is_reported_as_is_and_a_hanging_matcher_is_given_up(
        tmp_path: Path) -> None:
    from stereoforge.errors import StereoforgeError

    class MatcherFailure(StereoforgeError):  # what matcher.adapters raises
        pass

    calls = []

    def hangs(left, right, *, max_disparity):
        calls.append(1)
        raise MatcherFailure("timed out after 60 s")

    entries = run_battery(hangs, tmp_path)
    assert len(calls) == MAX_TIMEOUTS
    # one time-out per property (a property stops at its first failure), then no more calls
    assert all(e["explanation"].startswith("timed out after 60 s on ")
               for e in entries[:MAX_TIMEOUTS])
    assert all(e["explanation"].startswith(f"not called: it timed out {MAX_TIMEOUTS} times")
               for e in entries[MAX_TIMEOUTS:])
