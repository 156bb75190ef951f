"""The validate engine: axes registry, pair folders with region masks, results.csv, resume."""

from __future__ import annotations

import csv
import os

import numpy as np
import pytest
from click.testing import CliRunner

from matcher.io import read_image
from matcher.regions import REGIONS
from synth.cli import main
from synth.dataset.config.parse import config_from_dict
from synth.validate import axes as axes_mod
from synth.validate.axes import AXES, SUITES, Axis, axis_config, base_config, register_axis
from synth.validate.run import COLUMNS, TIMING_COLUMNS, plan, run_validate

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "user_matchers.py")
TINY = {"width": 64, "height": 48, "seeds": (0, 1)}
SOME_AXES = ("noise", "occluders", "textureless_fraction", "slant")


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def _untimed(rows):
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]


# --------------------------------------------------------------------------- the registry
def test_every_axis_changes_only_its_parameter_and_parses_as_a_dataset_config():
    from synth.validate.family import PHOTO_KEYS

    for suite in ("quick", "full"):
        for seed in SUITES[suite]["seeds"]:
            base = base_config(suite, seed)
            config_from_dict(base)
            for axis in AXES.values():
                assert len(axis.values(suite)) >= 3, axis.name
                for value in axis.values(suite):
                    cfg = axis_config(suite, axis, value, seed)
                    config_from_dict(cfg)  # a valid dataset config
                    changed = {(sec, k) for sec in cfg if isinstance(cfg[sec], dict)
                               for k in set(cfg[sec]) | set(base.get(sec, {}))
                               if cfg[sec].get(k) != base.get(sec, {}).get(k)}
                    if axis.key is not None:
                        assert tuple(axis.key.split(".")) in changed or \
                            base[axis.key.split(".")[0]].get(axis.key.split(".")[1]) == value
                    if axis.scene is not None and axis.key is None and axis.config is None:
                        assert changed == set(), axis.name
                    # photographs are dropped only where a procedural texture is needed
                    dropped = {k for sec, k in changed if k in PHOTO_KEYS}
                    assert not dropped or axis.name in ("edge_density", "repetitive_period")
                    assert len({c for c in changed if c[1] not in PHOTO_KEYS}) <= 2, (
                        axis.name, changed)


def test_each_seed_draws_its_own_base_scene():
    from synth.validate.family import FAMILY, member_name

    quick = [base_config("quick", s)["scene"] for s in SUITES["quick"]["seeds"]]
    assert len({q["base"] for q in quick}) == len(quick) == 3  # three different layouts
    assert any("object_image" in q for q in quick) and any("object_image" not in q
                                                           for q in quick)
    full = SUITES["full"]["seeds"]
    assert {member_name(s) for s in full} == {name for name, _ in FAMILY}
    assert base_config("full", 0)["scene"] != base_config("full", len(FAMILY))["scene"]


def test_an_axis_is_added_in_a_few_lines(monkeypatch):
    monkeypatch.setattr(axes_mod, "AXES", dict(AXES))
    register_axis(Axis("bias_only_full", "bias", quick=(1.0, 2.0), full=(3.0,),
                       key="photometric.bias"))
    assert axis_config("quick", axes_mod.AXES["bias_only_full"], 2.0)["photometric"]["bias"] == 2.0
    with pytest.raises(ValueError, match="give key, config or scene"):
        register_axis(Axis("nothing", "", (1,), (1,)))


def test_plan_order_and_folders():
    specs = plan("quick", ["noise", "slant"])
    assert [(s.axis, s.value, s.seed) for s in specs[:4]] == [
        ("noise", 0.0, 0), ("noise", 0.0, 1), ("noise", 0.0, 2), ("noise", 4.0, 0)]
    assert [s.scene for s in specs[:3]] == ["boxes", "flying", "slanted"]
    assert specs[0].config != specs[1].config
    assert specs[0].folder == "pairs/noise/0_s0"
    assert len({s.folder for s in plan("full")}) == len(plan("full"))


# --------------------------------------------------------------------------- the run
@pytest.fixture(scope="module")
def tiny_run(tiny_suite, tmp_path_factory, renderer):
    out = tmp_path_factory.mktemp("validate") / "a"
    res = run_validate(f"py:{HERE}:sad3", out=out, against=("ct:5",), axes=SOME_AXES,
                       battery=False, progress=False)
    return out, res


@pytest.mark.gl
def test_results_csv_rows_masks_and_estimates(tiny_run):
    out, res = tiny_run
    rows = _rows(out / "results.csv")
    assert tuple(rows[0]) == COLUMNS
    n_pairs = len(plan("quick", SOME_AXES))
    assert res.pairs_rendered == n_pairs and res.estimates_computed == 2 * n_pairs
    assert len(rows) == 2 * n_pairs * len(REGIONS)
    assert [r["region"] for r in rows[:5]] == list(REGIONS)
    assert {r["matcher"] for r in rows} == {f"py:{HERE}:sad3", "ct:5"}
    for r in rows:
        assert r["error"] == ""
        folder = out / r["sample"]
        for region in REGIONS:
            mask = read_image(folder / f"mask_{region}.png")
            assert mask.shape == (48, 64) and set(np.unique(mask)) <= {0, 255}
        assert (out / r["estimate"]).is_file()
        if r["bad_2"]:
            assert 0 <= float(r["bad_2"]) <= float(r["bad_1"]) <= float(r["bad_0_5"]) <= 1
            assert 0 <= float(r["coverage"]) <= 1 and float(r["mpix_disp_per_s"]) > 0
    by = {(r["matcher"], r["axis"], r["value"], r["seed"], r["region"]): r for r in rows}
    # the card makes a textureless region that the base scene lacks; the SAD fails on it
    card = by[f"py:{HERE}:sad3", "textureless_fraction", "0.5", "0", "textureless"]
    assert float(card["bad_2"]) > 0.5
    assert by["ct:5", "textureless_fraction", "0.0", "0", "textureless"]["bad_2"] == ""
    # a fronto-parallel plane has no depth edge, the boxes do
    assert by["ct:5", "slant", "0.0", "0", "discontinuity"]["bad_2"] == ""
    assert by["ct:5", "noise", "0.0", "0", "discontinuity"]["bad_2"] != ""
    # occluders add occluded pixels
    occ = [int((read_image(out / f"pairs/occluders/{v}_s0/mask_occluded.png") > 0).sum())
           for v in (0, 8)]
    assert occ[1] > occ[0]


@pytest.mark.gl
def test_same_config_same_bytes_and_resume_verifies(tiny_run, tmp_path):
    out, _ = tiny_run
    first, first_bytes = _rows(out / "results.csv"), (out / "results.csv").read_bytes()
    again = run_validate(f"py:{HERE}:sad3", out=out, against=("ct:5",), axes=SOME_AXES,
                         battery=False, progress=False)
    assert again.pairs_rendered == 0 and again.estimates_computed == 0
    assert (out / "results.csv").read_bytes() == first_bytes  # reused records, timings too
    # a damaged pair is rendered again, and only its estimates are recomputed
    victim = out / "pairs/noise/4_s1/im0.png"
    victim.write_bytes(victim.read_bytes()[:-10])
    (out / "estimates").joinpath("x").mkdir()  # unrelated clutter is ignored
    fixed = run_validate(f"py:{HERE}:sad3", out=out, against=("ct:5",), axes=SOME_AXES,
                         battery=False, progress=False)
    assert fixed.pairs_rendered == 1
    assert _untimed(_rows(out / "results.csv")) == _untimed(first)
    # a second folder from scratch: the same rows but the timing columns
    other = run_validate(f"py:{HERE}:sad3", out=tmp_path / "b", against=("ct:5",),
                         axes=SOME_AXES, battery=False, progress=False)
    assert _untimed(_rows(other.results)) == _untimed(first)


@pytest.mark.gl
def test_a_broken_matcher_is_recorded_per_sample(tiny_suite, tmp_path, renderer):
    res = run_validate(f"py:{HERE}:broken", out=tmp_path, against=("ct:5",), axes=("noise",),
                       battery=False, progress=False)
    rows = _rows(res.results)
    mine = [r for r in rows if r["matcher"].endswith(":broken")]
    assert mine and all(r["error"] == "crashed: ZeroDivisionError: user bug" for r in mine)
    assert all(r["estimate"] == "" and r["coverage"] in ("0.0", "") for r in mine)
    assert all(r["bad_4"] in ("1.0", "") for r in mine)
    assert all(r["error"] == "" for r in rows if r["matcher"] == "ct:5")


@pytest.mark.gl
def test_cli_validate(tiny_suite, tmp_path, renderer):
    runner = CliRunner()
    result = runner.invoke(main, ["validate", "ct:5", "--out", str(tmp_path), "--axes", "noise",
                                  "--against", "sgbm:5", "--skip-battery"])
    assert result.exit_code == 0, result.output
    assert "pairs: 6 rendered, 0 reused; estimates: 12 computed" in result.output
    assert len(_rows(tmp_path / "results.csv")) == 12 * len(REGIONS)


def test_cli_validate_bad_input(tmp_path):
    runner = CliRunner()
    result = runner.invoke(main, ["validate", "sad", "--out", str(tmp_path), "--axes", "noise",
                                  "--skip-battery"])
    assert result.exit_code == 2
    assert "Error: matcher 'sad': tried a built-in method 'sad'" in result.output
    result = runner.invoke(main, ["validate", "ct", "--out", str(tmp_path), "--axes", "nois"])
    assert result.exit_code == 2 and "--axes: unknown axis 'nois'" in result.output


@pytest.mark.gl
def test_a_hanging_matcher_times_out_per_sample_and_the_run_goes_on(tiny_suite, tmp_path,
                                                                     renderer, monkeypatch):
    monkeypatch.setenv("HANG_MARKER", str(tmp_path / "hung-once"))
    res = run_validate(f"py:{HERE}:sleepy", out=tmp_path / "v", against=(), axes=("noise",),
                       timeout=2.0, battery=False, progress=False)
    rows = [r for r in _rows(res.results) if r["region"] == "all"]
    errors = {(r["value"], r["seed"]): r["error"] for r in rows}
    assert errors.pop(("0.0", "0")) == "timed out after 2 s"  # the first pair
    assert set(errors.values()) == {""}  # a fresh child answered every later pair


@pytest.mark.gl
def test_hazard_axes_change_what_they_say_and_keep_the_exact_ground_truth():
    from synth.render import Renderer
    from synth.validate.axes import AXES, axis_config
    from synth.validate.pairs import render_sample

    def sample(name, value):
        axis = AXES[name]
        cfg = axis_config("quick", axis, value)
        cfg["rig"].update(width=64, height=48)
        return render_sample(cfg, 0, renderer, scene_hook=axis.scene, value=value)

    with Renderer(64, 48) as renderer:
        base_pair, base, _, _ = sample("exposure", 1.0)
        _, brighter, _, _ = sample("exposure", 2.0)
        assert brighter.right.mean() > base.right.mean() + 10  # the matcher's right view is im1E
        assert np.array_equal(brighter.left, base.left)
        relit_pair, relit, _, _ = sample("lighting_change", 90.0)
        assert not np.array_equal(relit.right, base.right)
        shiny_pair, _, scene, _ = sample("specular", 2.0)
        assert all(o.material.specular == 2.0 for o in scene.objects)
        _, _, fenced, _ = sample("thin_structures", 3)
        assert sum(o.kind == "fence" for o in fenced.objects) == 3
        offset_pair, offset, _, _ = sample("vertical_offset", 3.0)
        assert offset_pair.rig.errors is not None and offset_pair.flow_left is not None
        # the geometry (GT) is the ideal rig's: the same exact disparity as the base pair
        for pair in (relit_pair, shiny_pair, offset_pair):
            assert np.array_equal(pair.disp_left, base_pair.disp_left)


@pytest.mark.gl
@pytest.mark.slow
def test_cli_validate_end_to_end_battery_report_and_exit_status(tiny_suite, tmp_path, renderer):
    """The whole command: pairs, estimates, the property battery and report.html; exit 1 with
    --fail-on properties only when a required property fails."""
    import json

    runner = CliRunner()
    good = runner.invoke(main, ["validate", "ct:9", "--out", str(tmp_path / "good"), "--axes",
                                "noise", "--against", "sgbm:5", "--fail-on", "properties"])
    assert good.exit_code == 0, good.output
    doc = json.loads((tmp_path / "good" / "properties.json").read_text())
    assert doc["matcher"] and all(p["passed"] for p in doc["properties"] if p["required"])
    page = (tmp_path / "good" / "report.html").read_text()
    assert "sgbm:5" in page and "<img" in page and "No results.csv" not in page
    broken = f"py:{os.path.join(os.path.dirname(__file__), 'user_matchers.py')}:broken"
    for flags, status in (([], 0), (["--fail-on", "properties"], 1)):
        r = runner.invoke(main, ["validate", broken, "--out", str(tmp_path / "bad"), "--axes",
                                 "noise", "--against", "ct:5", *flags])
        assert r.exit_code == status, r.output
        assert "Traceback" not in r.output
    doc = json.loads((tmp_path / "bad" / "properties.json").read_text())
    failed = [p for p in doc["properties"] if p["required"] and not p["passed"]]
    assert failed and all("ZeroDivisionError" in p["explanation"] for p in failed)


@pytest.mark.gl
@pytest.mark.parametrize("axis", ["noise", "blur", "jpeg_quality"])
def test_region_masks_come_from_the_clean_render_at_every_level(tiny_suite, tmp_path, renderer,
                                                                 axis):
    """The regions of a pair are those of the noise-free render, so every level of a degradation
    axis is scored on the same pixels (regions made from the degraded left view would shrink the
    textureless region as noise rises)."""
    from matcher.regions import region_masks
    from synth.validate.pairs import PairSpec, render_pair_folder, render_sample

    seed = 2  # its base scene has flat areas
    specs = [PairSpec(axis, v, seed, axis_config("quick", AXES[axis], v, seed))
             for v in AXES[axis].values("quick")]
    assert len(specs) >= 3 and len({s.value for s in specs}) == len(specs)
    masks = []
    for spec in specs:
        render_pair_folder(spec, tmp_path, renderer)
        masks.append({n: read_image(tmp_path / spec.folder / f"mask_{n}.png") > 0
                      for n in REGIONS})
    # the degraded views differ between the levels, the masks do not
    lefts = [read_image(tmp_path / s.folder / "im0.png") for s in specs]
    assert any(not np.array_equal(lefts[0], other) for other in lefts[1:])
    pair, images, _, _ = render_sample(specs[-1].config, specs[-1].seed, renderer)
    clean = region_masks(pair.disp_left, pair.mask_left, pair.left)
    assert clean["textureless"].sum() > 50  # the region the degradation would shrink
    assert not np.array_equal(region_masks(pair.disp_left, pair.mask_left, images.left)
                              ["textureless"], clean["textureless"])  # so the check can fail
    for level in masks:
        for name in REGIONS:
            np.testing.assert_array_equal(level[name], clean[name], err_msg=name)
