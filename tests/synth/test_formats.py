"""The layouts behind one interface (synth.formats): the registry, what each can hold, reading back
every layout as one sample type, the new training layouts (sceneflow, crestereo, fsd) with their
refusals, resume and determinism, and every reader (StereoDataset, eval-dataset, validate --real,
train's sources, --compare across layouts) taking every layout."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from stereoforge.errors import ParameterError
from synth.dataset.config.parse import loads_config
from synth.dataset.run import run_dataset
from synth.formats import DATASET_FORMATS, FORMATS, READ_ONLY, get_layout, layouts

CONFIG = """\
name = "formats"
seed = 7
count = {count}

[rig]
width = 64
height = 48
{rig}
[scene]
base = {{choice = ["boxes", "flying", "slanted_plane"]}}
occluders = {{uniform = [1, 2]}}

[photometric]
noise_sigma = {{uniform = [1.0, 3.0]}}
"""
NEW = ("sceneflow", "crestereo", "fsd")
FOLDER_LAYOUTS = tuple(n for n in DATASET_FORMATS if get_layout(n).capacity.sample_folders)


def _config(count: int = 4, rig: str = "", source: str = "formats.toml"):
    return loads_config(CONFIG.format(count=count, rig=rig), source=source)


def _tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name != ".lock"}


@pytest.fixture(scope="module")
def datasets(tmp_path_factory, require_or_skip):
    """One small dataset of the config per folder layout (the GL backend is required)."""
    from synth.render.renderer import GLBackendError, Renderer

    try:
        with Renderer(8, 8):
            pass
    except GLBackendError as exc:
        require_or_skip(f"no OpenGL backend: {exc}", env="STEREOFORGE_REQUIRE_GL")
    base = tmp_path_factory.mktemp("formats")
    out = {}
    for name in FOLDER_LAYOUTS:
        out[name] = base / name
        run_dataset(_config(), out=out[name], fmt=name, progress=False)
    return out


# --------------------------------------------------------------------------- the registry
def test_every_format_is_one_registered_layout():
    assert set(DATASET_FORMATS) == {"middlebury", "middlebury2014", "kitti", "webdataset", *NEW}
    assert set(FORMATS) == set(DATASET_FORMATS) - {"webdataset"}
    # the registry's static list (read by the CLI without the layouts) is what they say
    assert list(FORMATS) == [n for n in DATASET_FORMATS if get_layout(n).capacity.sample_folders]
    for layout in layouts():
        assert get_layout(layout.name) is layout and layout.title
        assert layout.writable == (layout.name in DATASET_FORMATS)
        if layout.writable:
            assert layout.tools_root and layout.sample_parent
            assert layout.writes_as in FORMATS
    assert set(READ_ONLY) == {"middlebury2005", "eth3d", "drivingstereo", "skimage"}
    with pytest.raises(ValueError, match="unknown format 'pfm'; valid formats: middlebury"):
        get_layout("pfm")


def test_what_each_layout_can_hold():
    assert get_layout("kitti").capacity.disp_quantum == 1 / 256
    assert get_layout("crestereo").capacity.disp_quantum == 1 / 32
    assert get_layout("crestereo").capacity.disp_max == 65535 / 32
    assert get_layout("fsd").capacity.disp_quantum == 1 / 1000
    assert get_layout("fsd").capacity.disp_max == (255 ** 3 - 1) / 1000
    assert not get_layout("fsd").capacity.right_disparity
    for name in ("sceneflow", "middlebury", "middlebury2014"):
        cap = get_layout(name).capacity
        assert cap.disp_quantum is None and cap.disp_max is None and cap.lossless
    assert not get_layout("crestereo").capacity.lossless and not get_layout("fsd").capacity.lossless
    assert [n for n in DATASET_FORMATS if get_layout(n).capacity.flow] == [
        "middlebury", "middlebury2014", "webdataset"]


def test_no_code_outside_the_formats_package_compares_a_format_name():
    import re

    src = Path(__file__).resolve().parents[2] / "src"
    pattern = re.compile(r"fmt ==|fmt in|format ==")
    found = [f"{p.relative_to(src)}:{n}" for p in src.rglob("*.py")
             if "formats" not in p.relative_to(src).parts
             for n, line in enumerate(p.read_text().splitlines(), 1) if pattern.search(line)]
    assert found == []


def test_sceneflow_places_samples_by_index_alone():
    from synth.formats.sceneflow import place

    places = [place(i) for i in range(1000)]
    assert len(set(places)) == 1000  # one place per sample
    test = [i for i, p in enumerate(places) if p[0] == "TEST"]
    assert len(test) == 160  # 16 %, as FlyingThings3D
    assert place(21) == ("TEST", "A", 0, 0) and place(0) == ("TRAIN", "A", 0, 0)
    # a sequence holds 10 consecutive samples of one split
    assert [place(i)[1:3] for i in range(10)] == [("A", 0)] * 10 and place(10)[1:3] == ("B", 0)


# --------------------------------------------------------------------------- refusals
@pytest.mark.parametrize("fmt, rig, message", [
    ("crestereo", "near = 0.001\n", r"holds disparities up to 2047.97 px, but this rig makes up "
                                    r"to fx\*baseline/near = 6/0.001 = 6000 px; set \[rig\] "
                                    r"near >= 0.00293"),
    ("fsd", "near = 0.0001\n", r"holds disparities up to 16581.4 px"),
    ("fsd", "far = 20000.0\n", r"steps of 0.001 px, but this rig makes disparities down to "
                               r"fx\*baseline/far = 0.0003 px, which would read back as 'no "
                               r"ground truth'; set \[rig\] far <= 12000"),
    ("crestereo", "far = 1000.0\n", r"steps of 0.03125 px"),
])
def test_a_disparity_beyond_a_layout_is_refused_before_anything_is_rendered(
        fmt, rig, message, tmp_path):
    with pytest.raises(ParameterError, match=message):
        run_dataset(_config(rig=rig), out=tmp_path / "ds", fmt=fmt, progress=False)
    assert not (tmp_path / "ds").exists()


def test_the_command_line_refuses_it_in_one_line(tmp_path):
    from synth.cli import main

    cfg = tmp_path / "near.toml"
    cfg.write_text(CONFIG.format(count=2, rig="near = 0.001\n"))
    result = CliRunner().invoke(main, ["dataset", str(cfg), "--out", str(tmp_path / "o"),
                                       "--format", "crestereo"])
    assert result.exit_code == 2, result.output
    errors = [x for x in result.output.splitlines() if x.startswith("Error:")]
    assert len(errors) == 1 and "--format crestereo holds disparities up to" in errors[0]
    assert not (tmp_path / "o").exists()


def test_what_a_layout_has_no_place_for_is_refused(tmp_path):
    from stereoforge.errors import DatasetError

    with pytest.raises(ParameterError, match="has no place in the FoundationStereo FSD layout"):
        text = CONFIG.format(count=1, rig="").replace("seed = 7", 'seed = 7\nground_truth = ["depth"]')
        run_dataset(loads_config(text), out=tmp_path / "a", fmt="fsd", progress=False)
    with pytest.raises(DatasetError, match="flow0.flo, which the SceneFlow"):
        run_dataset(_config(rig="right_rz_deg = 0.5\n"), out=tmp_path / "b", fmt="sceneflow",
                    progress=False)


# --------------------------------------------------------------------------- what is written
@pytest.mark.gl
def test_sceneflow_names_hold_the_replaced_words_only_where_the_layout_puts_them(datasets):
    from synth.formats.sceneflow import PASSES

    root = datasets["sceneflow"]
    files = [p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()]
    assert files
    for rel in files:
        parts = rel.split("/")
        for k, part in enumerate(parts):
            if part in ("left", "right"):  # the view folder, right above the file
                assert k == len(parts) - 2 and parts[2] in (*PASSES, "disparity"), rel
            else:
                assert "left" not in part and "right" not in part, rel
            if "frames_" in part:
                assert part in PASSES and k == 2, rel
            if ".png" in part:
                assert k == len(parts) - 1 and part.endswith(".png") and parts[2] in PASSES, rel


@pytest.mark.gl
def test_sceneflow_pfm_header_and_both_passes(datasets):
    from synth.formats.sceneflow import place

    things = datasets["sceneflow"] / "SceneFlow" / "FlyingThings3D"
    split, letter, sequence, frame = place(1)
    seq = f"{split}/{letter}/{sequence:04d}"
    data = (things / "disparity" / seq / "left" / f"{frame:04d}.pfm").read_bytes()
    assert data.startswith(b"Pf\n64 48\n-1\n") and len(data) == len(b"Pf\n64 48\n-1\n") + 64 * 48 * 4
    clean = (things / "frames_cleanpass" / seq / "left" / f"{frame:04d}.png").read_bytes()
    final = (things / "frames_finalpass" / seq / "left" / f"{frame:04d}.png").read_bytes()
    assert clean != final  # the photometric models apply to the final pass only
    calib = (datasets["sceneflow"] / "samples" / "000001" / "calib.txt").read_text()
    assert calib.startswith("cam0=[60 0 31.5; 0 60 23.5; 0 0 1]") and "baseline=100" in calib


@pytest.mark.gl
@pytest.mark.parametrize("fmt", FOLDER_LAYOUTS)
def test_every_layout_reads_back_as_one_sample_type(datasets, fmt):
    """StereoDataset reads every layout: the same images as the default layout (after JPEG where
    the layout stores JPEG), the same ground truth within the layout's quantum, a mask, calib."""
    from synth.dataset.compare_layouts import compare_layouts
    from synth.dataset.loader import StereoDataset

    data = StereoDataset(datasets[fmt])
    reference = StereoDataset(datasets["middlebury"])
    assert len(data) == len(reference) == 4
    layout = get_layout(fmt)
    tolerance = layout.capacity.disp_quantum or 0.0
    for i in range(4):
        a, b = data[i], reference[i]
        assert a["left"].shape == (48, 64, 3) and a["disp"].dtype == np.float32
        np.testing.assert_array_equal(a["valid"], b["valid"])
        np.testing.assert_allclose(a["disp"][a["valid"]], b["disp"][b["valid"]], rtol=0,
                                   atol=tolerance)
        assert a["calib"] == b["calib"]
        assert ("disp_right" in a) == layout.capacity.right_disparity
        if layout.capacity.lossless:
            np.testing.assert_array_equal(a["left"], b["left"])
        s = data.sample(i)
        assert set(np.unique(s.mask_left)) <= {0, 128, 255}
        assert ((s.mask_left == 0) == ~np.isfinite(s.disp_left)).all()
    assert compare_layouts(datasets["middlebury"], datasets[fmt]) == []


@pytest.mark.gl
def test_compare_across_layouts_finds_a_changed_disparity(datasets, tmp_path):
    import shutil

    from matcher.io import encode_crestereo_disparity, read_crestereo_disparity
    from synth.dataset.compare_layouts import compare_layouts

    copy = tmp_path / "c"
    shutil.copytree(datasets["crestereo"], copy)
    path = copy / "CREStereo" / "tree" / "000000_left.disp.png"
    disp = read_crestereo_disparity(path)
    r, c = np.argwhere(np.isfinite(disp))[0]
    disp[r, c] += 0.25
    path.write_bytes(encode_crestereo_disparity(disp))
    found = compare_layouts(datasets["middlebury"], copy)
    assert [d.path for d in found] == ["000000"]
    assert "1 disparities differ by more than the quantum 0.03125 px" in found[0].detail


@pytest.mark.gl
@pytest.mark.parametrize("fmt", NEW)
def test_same_bytes_whatever_the_worker_count(datasets, fmt, tmp_path):
    out = tmp_path / "two"
    run_dataset(_config(), out=out, fmt=fmt, workers=2, progress=False)
    assert _tree(out) == _tree(datasets[fmt])


@pytest.mark.gl
@pytest.mark.parametrize("fmt", NEW)
def test_verify_and_a_damaged_file(datasets, fmt, tmp_path):
    import shutil

    from synth.dataset.storage.integrity import verify_dataset

    assert verify_dataset(datasets[fmt]) == []
    copy = tmp_path / "d"
    shutil.copytree(datasets[fmt], copy)
    victim = sorted(p for p in (copy / get_layout(fmt).tools_root).rglob("*") if p.is_file()
                    and "sceneflow_" not in p.name)[0]
    victim.write_bytes(victim.read_bytes()[:-1])
    (copy / get_layout(fmt).tools_root / "stray.txt").write_text("x")
    problems = verify_dataset(copy)
    rel = victim.relative_to(copy).as_posix()
    assert any(p.startswith(f"{rel}: ") and "truncated" in p for p in problems), problems
    assert any(p.startswith(f"{get_layout(fmt).tools_root}/stray.txt: extra file") for p in problems)


_RUNNER = """
import sys
from synth.dataset.run import run_dataset
from synth.dataset.config.parse import load_config
run_dataset(load_config(sys.argv[1]), out=sys.argv[2], fmt=sys.argv[3], progress=False)
"""


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.parametrize("fmt", NEW)
def test_killed_and_resumed_gives_the_uninterrupted_bytes(fmt, tmp_path, sigkill_after_records):
    config = tmp_path / "cfg.toml"
    config.write_text(CONFIG.format(count=12, rig=""))
    reference = tmp_path / "ref"
    run_dataset(_config(count=12, source=str(config)), out=reference, fmt=fmt, progress=False)
    script = tmp_path / "runner.py"
    script.write_text(textwrap.dedent(_RUNNER))
    out = tmp_path / "ds"
    proc = subprocess.Popen([sys.executable, str(script), str(config), str(out), fmt],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    sigkill_after_records(proc, out, 3, timeout=60)
    assert proc.returncode != 0
    run = run_dataset(_config(count=12, source=str(config)), out=out, fmt=fmt, progress=False)
    assert run.skipped >= 3 and run.rendered + run.skipped == 12
    assert _tree(out) == _tree(reference)


# --------------------------------------------------------------------------- the readers
@pytest.mark.gl
@pytest.mark.parametrize("fmt", NEW)
def test_validate_real_reads_a_tree_of_each_training_layout(datasets, fmt):
    from synth.validate.real import resolve_real

    scenes = resolve_real([f"{fmt}:{datasets[fmt]}"])
    assert len(scenes) == 4
    left, right, gt, mask, how = scenes[0].load()
    assert left.shape == (48, 64, 3) and np.isfinite(gt).any()
    assert "left-right check" in how
    with pytest.raises(ParameterError, match=f"--real '{fmt}:.*': no sample with ground truth"):
        resolve_real([f"{fmt}:{datasets['middlebury']}"])


@pytest.mark.gl
@pytest.mark.parametrize("fmt", NEW)
def test_eval_dataset_scores_every_layout(datasets, fmt, tmp_path):
    import csv

    from synth.jobs.eval_dataset import eval_dataset

    results = eval_dataset(datasets[fmt], matcher="sgbm:5", out=tmp_path / "e")
    with results.open() as f:
        rows = list(csv.DictReader(f))
    assert {r["region"] for r in rows} == {"all", "nonocc", "occluded"}
    assert len({r["index"] for r in rows}) == 4 and all(r["error"] == "" for r in rows)


@pytest.mark.gl
def test_compare_across_layouts_on_the_command_line(datasets):
    from synth.cli import main

    a, b = str(datasets["middlebury"]), str(datasets["sceneflow"])
    result = CliRunner().invoke(main, ["dataset", "--compare", a, b])
    assert result.exit_code == 0, result.output
    assert result.output.splitlines()[-1] == (f"{a} vs {b}: the same samples (pixels, ground "
                                              "truth within the quantum, calibration)")
    result = CliRunner().invoke(main, ["dataset", "--compare", a, b, "--bytes"])
    assert result.exit_code == 2 and "cannot be byte-identical" in result.output


def test_a_sceneflow_dataset_too_small_for_a_test_split_says_so(tmp_path, renderer):
    from click.testing import CliRunner

    from synth.cli import main

    layout = get_layout("sceneflow")
    assert layout.count_note(22) is None and layout.count_note(10**5) is None
    assert "with 21 sample(s) the TEST split is empty" in layout.count_note(21)
    assert all(get_layout(n).count_note(1) is None for n in DATASET_FORMATS if n != "sceneflow")
    result = CliRunner().invoke(main, [
        "dataset", "planes", "--format", "sceneflow", "--count", "2", "--size", "32x24",
        "--out", str(tmp_path / "sf")])
    assert result.exit_code == 0, result.output
    notes = [x for x in result.stderr.splitlines() if x.startswith("note: --format sceneflow")]
    assert len(notes) == 1 and "render --count 22 or more for a TEST split" in notes[0]
    assert not list((tmp_path / "sf").glob("SceneFlow/FlyingThings3D/*/TEST"))


def test_the_sceneflow_reader_takes_the_final_pass_where_the_passes_differ(datasets):
    """The final pass holds the config's photometric models (noise here), the clean pass not:
    a tree whose passes differ shows which one a reader takes (a preference for the clean pass
    fails)."""
    from matcher.io import read_image
    from synth.formats import resolve_spec

    out = datasets["sceneflow"]
    keys = get_layout("sceneflow").discover(out)
    assert keys and all("/frames_finalpass/" in k for k in keys)
    refs = resolve_spec(f"sceneflow:{out}")
    assert len(refs) == 4
    for ref in refs:
        final = read_image(out / ref.key)
        clean = read_image(out / ref.key.replace("frames_finalpass", "frames_cleanpass"))
        assert not np.array_equal(final, clean)  # the passes differ here
        np.testing.assert_array_equal(ref.read().left, final)
