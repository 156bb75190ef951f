"""The texture-versus-window study: config parsing, files, resumability, determinism."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from synth.jobs.study.run import (
    COLUMNS,
    StudyConfigError,
    list_studies,
    load_study_config,
    loads_study_config,
    run_study,
)

TINY = """\
name = "tiny"
seeds = [3]
max_disparity = 8

[rig]
width = 64
height = 48

[scene]
kinds = ["slanted_plane"]
frequencies_px = [0.05, 0.15]
contrasts = [0.8]
noise_sigma = 1.0

[match]
methods = ["ct", "awct"]
windows = [5, 15]
"""


# --------------------------------------------------------------------------- config
def test_shipped_config_loads_by_name_and_by_path():
    assert "study-texture-window" in list_studies()
    cfg = load_study_config("texture-window")
    assert load_study_config("study-texture-window") == cfg
    assert cfg.axis == "frequency" and cfg.rig.width == 320
    assert {"ct", "sct", "cthw", "awct", "awsct", "sgbm"} == set(cfg.methods)
    assert len(cfg.cells()) == len(cfg.kinds) * len(cfg.levels) * len(cfg.contrasts) * len(
        cfg.seeds)


def test_tiny_config_values(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    cfg = load_study_config(path)
    assert (cfg.name, cfg.seeds, cfg.levels, cfg.windows) == ("tiny", (3,), (0.05, 0.15), (5, 15))
    assert cfg.rig.fx == 60.0 and cfg.noise_sigma == 1.0
    assert cfg.cells() == [("slanted_plane", 0.05, 0.8, 3), ("slanted_plane", 0.15, 0.8, 3)]


def test_unknown_key_names_file_line_and_valid_keys():
    text = TINY.replace("noise_sigma = 1.0", "noise_sigma = 1.0\nfrequency = 3")
    with pytest.raises(StudyConfigError) as exc:
        loads_study_config(text, source="s.toml")
    msg = str(exc.value)
    assert msg.startswith("s.toml:14: unknown key 'frequency' in [scene]; valid keys: ")
    assert "'edge_densities'" in msg and msg.endswith("did you mean 'frequencies_px'?")
    with pytest.raises(StudyConfigError, match=r"^s\.toml:1: unknown key 'colour' in the "
                                               r"top-level table; valid keys: \['name', "):
        loads_study_config("colour = 1\n" + TINY, source="s.toml")


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('methods = ["ct", "awct"]', 'methods = ["ct", "sad"]', r"tiny\.toml:16: match\.methods\[1\]: expected one of \['ct', .*\], got 'sad'"),
        ("windows = [5, 15]", "windows = [4, 15]", r"tiny\.toml:17: match\.windows\[0\]: expected an odd integer in \[3, 255\], got 4"),
        ("frequencies_px = [0.05, 0.15]", "frequencies_px = [0.6]", r"tiny\.toml:11: .*\(0, 0\.5\)"),
        ("frequencies_px = [0.05, 0.15]", "edge_densities = [0.1]\nfrequencies_px = [0.1]",
         r"exactly one of"),
        ("max_disparity = 8", "max_disparity = 64", r"tiny\.toml:3: max_disparity: expected an integer in \[1, 64\), got 64"),
        ("seeds = [3]", 'seeds = "3"', r"tiny\.toml:2: seeds: expected a non-empty array"),
        ('kinds = ["slanted_plane"]', 'kinds = ["ocean"]', r"tiny\.toml:10: scene\.kinds\[0\]: expected one of \[.*'slanted_plane'.*\], got 'ocean'"),
    ],
)
def test_bad_values_name_the_line(old, new, message):
    assert old in TINY
    with pytest.raises(StudyConfigError, match=message):
        loads_study_config(TINY.replace(old, new), source="tiny.toml")


@pytest.mark.parametrize(
    "old, new, message",
    [
        ('methods = ["ct", "awct"]\nwindows = [5, 15]', 'methods = ["bm"]\nwindows = [3, 5]',
         r"tiny\.toml:17: match\.windows: expected windows >= 5 when methods include 'bm'"),
        ("windows = [5, 15]", "windows = [5, 5]", r"tiny\.toml:17: match\.windows: expected "
                                                  r"distinct .*, got 5 twice"),
        ("width = 64", "width = 0", r"tiny\.toml:6: rig\.width: expected an integer > 0, got 0"),
        ("height = 48", "height = 12", r"tiny\.toml:17: match\.windows: .*fit in the image, <= 12"),
        ("[rig]\nwidth = 64\nheight = 48", "rig = 3", r"tiny\.toml:5: rig: expected a table \[rig\]"),
    ],
)
def test_relations_and_tables_name_the_line(old, new, message):
    assert old in TINY
    with pytest.raises(StudyConfigError, match=message):
        loads_study_config(TINY.replace(old, new), source="tiny.toml")


def test_lines_after_a_multiline_description():
    # [match] and windows inside the description are text, not a table and a key
    text = ('description = """\n[match]\nwindows = [4]\n"""\n' + TINY).replace(
        "windows = [5, 15]", "windows = [5, 16]")
    with pytest.raises(StudyConfigError, match=r"^tiny\.toml:21: match\.windows\[1\]"):
        loads_study_config(text, source="tiny.toml")


def test_missing_config_file_lists_shipped_studies(tmp_path):
    with pytest.raises(FileNotFoundError, match="study-texture-window"):
        load_study_config(tmp_path / "nope.toml")


# --------------------------------------------------------------------------- running (GL)
def _inodes(out: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(out)): (p.stat().st_ino, p.stat().st_mtime_ns)
            for p in sorted((out / "cells").rglob("*.json"))}


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("study")
    config = root / "tiny.toml"
    config.write_text(TINY)
    out = run_study(config, out=root / "a", progress=False)
    return config, out


@pytest.mark.gl
def test_study_writes_files_with_the_right_columns(renderer, tiny_run):
    _, out = tiny_run
    for name in ("results.csv", "summary.md", "pobmp_heatmap.png", "ops_accuracy.png",
                 "config.toml"):
        assert (out / name).is_file(), name
    with (out / "results.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == COLUMNS
    assert len(rows) == 2 * 2 * 2  # frequencies x methods x windows (1 seed, 1 contrast)
    assert [(r["texture_level"], r["method"], r["window"]) for r in rows[:4]] == [
        ("0.05", "ct", "5"), ("0.05", "ct", "15"), ("0.05", "awct", "5"), ("0.05", "awct", "15")]
    for r in rows:
        assert 0 <= float(r["pobmp"]) <= 100 and 0 <= float(r["invalid"]) <= 100
        assert 0 < float(r["edge_density"]) < 1
        assert int(r["census_comparisons"]) > 0
    by = {(r["texture_level"], r["method"], r["window"]): r for r in rows}
    # CT's operations are closed-form; AWCT never needs more than CT at the same window
    assert int(by["0.05", "ct", "15"]["census_comparisons"]) == 2 * 64 * 48 * (15 * 15 - 1)
    assert float(by["0.05", "awct", "15"]["ops_vs_ct"]) <= 1.0
    # AWCT equals CT below 13 x 13 (N = 5 decreases from 3 x 3 cannot happen earlier)
    assert by["0.15", "awct", "5"]["pobmp"] == by["0.15", "ct", "5"]["pobmp"]
    # the denser texture has more edges
    assert float(by["0.15", "ct", "5"]["edge_density"]) > float(by["0.05", "ct", "5"]["edge_density"])
    summary = (out / "summary.md").read_text()
    assert "## PoBMP (%), slanted_plane, contrast 0.8" in summary
    assert "## AWCT − CT (paired: same pair, same window)" in summary


@pytest.mark.gl
def test_study_resumes_without_recomputing(renderer, tiny_run):
    config, out = tiny_run
    before = _inodes(out)
    csv_before = (out / "results.csv").read_bytes()
    assert len(before) == 2
    run_study(config, out=out, progress=False)
    assert _inodes(out) == before  # no cell was recomputed (atomic writes change the inode)
    assert (out / "results.csv").read_bytes() == csv_before
    # a missing or stale cell is recomputed, and only that one
    first = out / next(iter(before))
    first.unlink()
    second = out / list(before)[1]
    record = json.loads(second.read_text())
    record["fingerprint"] = "stale"
    second.write_text(json.dumps(record))
    run_study(config, out=out, progress=False)
    after = _inodes(out)
    assert set(after) == set(before)
    assert all(after[k] != before[k] for k in before)
    assert (out / "results.csv").read_bytes() == csv_before


@pytest.mark.gl
@pytest.mark.slow
def test_study_is_deterministic_across_runs_and_workers(renderer, tiny_run, tmp_path):
    config, out = tiny_run
    again = run_study(config, out=tmp_path / "b", workers=2, progress=False)
    assert (again / "results.csv").read_bytes() == (out / "results.csv").read_bytes()
    assert (again / "summary.md").read_bytes() == (out / "summary.md").read_bytes()


def test_summary_intervals_are_t_based():
    from synth.jobs.study.report import _interval

    mean, half, n = _interval([1.0, 2.0, 3.0])
    assert (mean, n) == (2.0, 3)
    assert half == pytest.approx(4.302652729911275 * 1.0 / math.sqrt(3))  # t(0.975, 2)
    assert math.isnan(_interval([5.0])[1])
