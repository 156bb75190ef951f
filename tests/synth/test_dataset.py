"""run_dataset / render_from_manifest: determinism, resume after a kill, refusal, failures."""

from __future__ import annotations

import fcntl
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from synth.dataset.compare import compare_datasets, summarize
from synth.dataset.config.parse import loads_config
from synth.dataset.run import (
    DatasetError,
    SampleError,
    read_manifest,
    render_from_manifest,
    run_dataset,
)
from synth.dataset.config.sampling import draw_sample, sample_seed

CONFIG = """\
name = "tiny"
seed = 11
count = 12

[rig]
width = 48
height = 32

[scene]
base = {choice = ["fronto_plane", "boxes", "flying"]}
texture = {choice = ["preset", "noise"]}
contrast = {uniform = [0.5, 1.0]}
occluders = {uniform = [0, 2]}
occluder_size = {uniform = [0.1, 0.3]}
occluder_depth = {uniform = [1.0, 1.5]}
occluder_kind = {choice = ["box", "sphere", "cylinder"]}

[photometric]
noise_sigma = {uniform = [0.0, 3.0]}
gain = {uniform = [0.9, 1.1]}
bias = {uniform = [-5.0, 5.0]}
gamma = {uniform = [0.8, 1.2]}
blur_sigma = {choice = [0.0, 0.7]}
jpeg_quality = {choice = [0, 90]}
"""
MIDDLEBURY_FILES = {"im0.png", "im1.png", "im1E.png", "im1L.png", "disp0GT.pfm", "disp1GT.pfm",
                    "mask0nocc.png", "calib.txt",
                    "scene.json", "sample.json"}
RECORDS = "records"  # the samples' completion records, records/NNNNNN.json (not sample files)


def _record(root: Path, i: int) -> Path:
    return root / RECORDS / f"{i:06d}.json"


_PARENTS = {"middlebury": "MiddEval3/trainingF", "middlebury2014": "2014",
            "kitti": "training/samples"}


def _sample(root: Path, i: int, fmt: str = "middlebury") -> Path:
    return root / _PARENTS[fmt] / f"{i:06d}"


def _tree(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def _assert_same_tree(a: Path, b: Path) -> None:
    """The same bytes in every file; a failure says, per file, whether its content differs (how
    many pixels or values, where) or only its encoding (synth.dataset.compare)."""
    differences = compare_datasets(a, b)
    assert not differences, f"{summarize(differences)}:\n" + "\n".join(
        f"{d.kind}: {d}" for d in differences)


@pytest.fixture(scope="module")
def config_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("cfg") / "tiny.toml"
    path.write_text(CONFIG)
    return path


@pytest.fixture(scope="module")
def reference(config_file, tmp_path_factory, renderer) -> Path:
    out = tmp_path_factory.mktemp("ref") / "ds"
    run = run_dataset(config_file, out=out, workers=1, progress=False)
    assert (run.count, run.rendered, run.skipped) == (12, 12, 0)
    return out


@pytest.mark.gl
def test_layout_and_manifest(reference, config_file):
    names = sorted(p.name for p in reference.iterdir())
    assert names == [".lock", "MiddEval3", "dataset.json", "manifest.csv", "manifest.jsonl",
                     RECORDS]
    assert sorted(p.name for p in (reference / RECORDS).iterdir()) == [
        f"{i:06d}.json" for i in range(12)]
    assert sorted(p.name for p in (reference / "MiddEval3").iterdir()) == [
        "official_train.txt", "trainingF"]
    scenes = [f"{i:06d}" for i in range(12)]
    assert sorted(p.name for p in (reference / "MiddEval3" / "trainingF").iterdir()) == scenes
    assert (reference / "MiddEval3" / "official_train.txt").read_text().splitlines() == scenes
    for i in range(12):
        assert {p.name for p in _sample(reference, i).iterdir()} == MIDDLEBURY_FILES
    header = json.loads((reference / "dataset.json").read_text())
    assert header["layout"] == 2
    cfg = loads_config(CONFIG, source=str(config_file))
    assert header["config_hash"] == cfg.hash() and header["format"] == "middlebury"
    lines = (reference / "manifest.jsonl").read_text().splitlines()
    records = [json.loads(line) for line in lines]
    assert [r["index"] for r in records] == list(range(12))
    assert records == read_manifest(reference)
    for r in records:
        assert r["seed"] == sample_seed(11, r["index"])
        assert r["params"] == json.loads(json.dumps(draw_sample(cfg, r["index"]).params))
        s = r["stats"]
        assert 0 <= s["edge_density"] < 1 and 0 <= s["occluded_fraction"] < 1
        assert 0 < s["disp_min"] <= s["disp_max"]
    csv_lines = (reference / "manifest.csv").read_text().splitlines()
    head = csv_lines[0].split(",")
    assert head[:3] == ["index", "seed", "dir"]
    assert "params.photometric.gain" in head and "stats.edge_density" in head
    assert [line.split(",")[0] for line in csv_lines[1:]] == [str(i) for i in range(12)]
    # the drawn parameters vary from sample to sample
    assert len({r["params"]["photometric.gain"] for r in records}) == 12


@pytest.mark.gl
@pytest.mark.slow
def test_two_workers_write_the_same_bytes_as_one(reference, config_file, tmp_path):
    out = tmp_path / "ds"
    run_dataset(config_file, out=out, workers=2, progress=False)
    _assert_same_tree(reference, out)


@pytest.mark.gl
def test_growing_count_extends_with_the_same_bytes(reference, config_file, tmp_path):
    out = tmp_path / "ds"
    first = run_dataset(config_file, out=out, count=3, workers=1, progress=False)
    assert (first.rendered, first.skipped) == (3, 0)
    second = run_dataset(config_file, out=out, count=5, workers=1, progress=False)
    assert (second.rendered, second.skipped) == (2, 3)
    for i in range(5):
        _assert_same_tree(_sample(reference, i), _sample(out, i))
    assert [r["index"] for r in read_manifest(out)] == list(range(5))


@pytest.mark.gl
def test_render_from_manifest_reproduces_a_sample(reference, tmp_path):
    files = render_from_manifest(reference, 7, out=tmp_path / "one")
    assert {f.name for f in files} == MIDDLEBURY_FILES
    _assert_same_tree(_sample(reference, 7), tmp_path / "one")


def test_another_config_or_format_is_refused(config_file, tmp_path):
    out = tmp_path / "ds"
    out.mkdir()
    cfg = loads_config(CONFIG)
    (out / "dataset.json").write_text(json.dumps({"name": "tiny", "format": "middlebury",
                                                  "config_hash": cfg.hash()}))
    other = loads_config(CONFIG.replace("seed = 11", "seed = 12"), source="other.toml")
    with pytest.raises(DatasetError, match=r"another configuration than other\.toml"):
        run_dataset(other, out=out, progress=False)
    with pytest.raises(DatasetError, match=r"format 'kitti'"):
        run_dataset(cfg, out=out, fmt="kitti", progress=False)


def test_a_dataset_of_another_sample_format_version_is_refused(tmp_path):
    out = tmp_path / "ds"
    out.mkdir()
    cfg = loads_config(CONFIG)
    (out / "dataset.json").write_text(json.dumps({"name": "tiny", "format": "middlebury",
                                                  "config_hash": cfg.hash(),
                                                  "format_version": 1}))
    with pytest.raises(DatasetError, match=r"sample format version 1, written by another "
                                           r"stereoforge version; this one writes version 2"):
        run_dataset(cfg, out=out, progress=False)
    assert sorted(p.name for p in out.iterdir()) == [".lock", "dataset.json"]


def test_a_foreign_directory_or_a_busy_one_is_refused(tmp_path):
    cfg = loads_config(CONFIG)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(DatasetError, match=r"not empty \(notes\.txt\)"):
        run_dataset(cfg, out=foreign, progress=False)
    busy = tmp_path / "busy"
    busy.mkdir()
    fd = os.open(busy / ".lock", os.O_RDWR | os.O_CREAT)
    try:
        fcntl.lockf(fd, fcntl.LOCK_EX)  # a record lock, as runs take (synth.dataset.parts)
        with pytest.raises(DatasetError, match="another run is writing"):
            run_dataset(cfg, out=busy, progress=False)
    finally:
        os.close(fd)


def test_arguments_are_validated(tmp_path):
    cfg = loads_config(CONFIG)
    for kwargs, match in [({"count": 0}, "count"), ({"fmt": "png"}, "fmt must be one of"),
                          ({"engine": "dask"}, "engine must be one of"),
                          ({"workers": 0}, "workers must be")]:
        with pytest.raises(ValueError, match=match):
            run_dataset(cfg, out=tmp_path / "x", progress=False, **kwargs)


@pytest.mark.gl
def test_a_failing_sample_leaves_no_files_and_names_its_index_and_seed(tmp_path, renderer):
    # far = 4.5 m: the boxes preset's wall (5 m) is out of range, the fronto plane (2 m) is not
    text = CONFIG.replace("height = 32", "height = 32\nfar = 4.5").replace(
        'base = {choice = ["fronto_plane", "boxes", "flying"]}',
        'base = {choice = ["fronto_plane", "boxes"]}')
    cfg = loads_config(text)
    bad = next(i for i in range(12) if draw_sample(cfg, i).params["scene.base"] == "boxes")
    assert bad > 0, "the test needs a good sample before the bad one"
    out = tmp_path / "ds"
    with pytest.raises(SampleError, match=rf"sample {bad} \(seed {sample_seed(11, bad)}\)") as e:
        run_dataset(cfg, out=out, workers=1, progress=False)
    assert "far" in str(e.value) and "render_from_manifest" in str(e.value)
    names = sorted(p.name for p in out.iterdir())
    assert names == [".lock", "MiddEval3", "dataset.json", "manifest.csv", "manifest.jsonl",
                     RECORDS]
    assert sorted(p.name for p in (out / "MiddEval3" / "trainingF").iterdir()) == [
        f"{i:06d}" for i in range(bad)]
    assert len(read_manifest(out)) == bad
    with pytest.raises(SampleError, match=rf"sample {bad} \(seed {sample_seed(11, bad)}\)"):
        render_from_manifest(out, bad, out=tmp_path / "again")


@pytest.mark.gl
def test_kitti_layout(config_file, tmp_path, renderer):
    out = tmp_path / "kitti"
    run_dataset(config_file, out=out, count=2, fmt="kitti", progress=False)
    subs = ("image_2", "image_3", "disp_occ_0", "disp_noc_0", "obj_map")
    for sub in subs:
        assert sorted(p.name for p in (out / "training" / sub).iterdir()) == ["000000_10.png",
                                                                              "000001_10.png"]
    assert sorted(p.name for p in (out / "training" / "calib_cam_to_cam").iterdir()) == [
        "000000.txt", "000001.txt"]
    assert {p.name for p in _sample(out, 1, "kitti").iterdir()} == {"scene.json", "sample.json"}
    assert sorted(p.name for p in out.iterdir()) == [".lock", "dataset.json", "manifest.csv",
                                                     "manifest.jsonl", RECORDS, "training"]
    assert [r["index"] for r in read_manifest(out)] == [0, 1]
    files = render_from_manifest(out, 1, out=tmp_path / "one")
    assert sorted(str(f.relative_to(tmp_path / "one")) for f in files) == sorted(
        [f"training/{s}/000001_10.png" for s in subs]
        + ["training/calib_cam_to_cam/000001.txt", "scene.json", "sample.json"])
    for sub in ("image_2", "disp_noc_0", "obj_map"):
        assert (out / "training" / sub / "000001_10.png").read_bytes() == \
            (tmp_path / "one" / "training" / sub / "000001_10.png").read_bytes()


@pytest.mark.gl
def test_middlebury_2014_layout_is_the_middeval3_samples_renamed(reference, config_file,
                                                                 tmp_path):
    """``fmt="middlebury2014"``: ``2014/NNNNNN/`` holds the scene folders alone (RAFT-Stereo's
    ``split="2014"`` takes every entry for one), each with the MiddEval3 sample's bytes and the
    ground truth named ``disp0.pfm``/``disp1.pfm``; resume, verify and render_from_manifest as
    in the other layouts."""
    from synth.dataset.storage.integrity import verify_dataset

    out = tmp_path / "mb2014"
    run_dataset(config_file, out=out, count=3, fmt="middlebury2014", progress=False)
    assert sorted(p.name for p in out.iterdir()) == [".lock", "2014", "dataset.json",
                                                     "manifest.csv", "manifest.jsonl", RECORDS]
    assert sorted(p.name for p in (out / "2014").iterdir()) == ["000000", "000001", "000002"]
    assert json.loads((out / "dataset.json").read_text())["format"] == "middlebury2014"
    renamed = {"disp0GT.pfm": "disp0.pfm", "disp1GT.pfm": "disp1.pfm"}
    for i in range(3):
        theirs, ours = _tree(_sample(reference, i)), _tree(_sample(out, i, "middlebury2014"))
        scene = json.loads(ours.pop("scene.json"))  # it names the format
        assert scene == {**json.loads(theirs.pop("scene.json")), "format": "middlebury2014"}
        assert ours == {renamed.get(k, k): v for k, v in theirs.items()}
        theirs["scene.json"] = b""
        assert sorted(json.loads(_record(out, i).read_text())["files"]) == sorted(
            f"2014/{i:06d}/{renamed.get(k, k)}" for k in theirs)
    assert read_manifest(out) == read_manifest(reference)[:3]
    assert verify_dataset(out) == []
    clean = _tree(out)
    (_sample(out, 1, "middlebury2014") / "disp0.pfm").write_bytes(b"Pf\n")
    (out / "2014" / "notes.txt").write_text("not a scene")
    assert verify_dataset(out, checksums=False) == [
        f"2014/000001/disp0.pfm: 3 bytes, its record says "
        f"{len(clean['2014/000001/disp0.pfm'])} bytes (truncated or replaced)",
        "2014/notes.txt: extra file (no sample's record lists it)"]
    (out / "2014" / "notes.txt").unlink()
    run = run_dataset(config_file, out=out, count=3, fmt="middlebury2014", progress=False)
    assert (run.rendered, run.skipped) == (1, 2)
    assert _tree(out) == clean
    files = render_from_manifest(out, 2, out=tmp_path / "one")
    assert sorted(f.name for f in files) == sorted(_tree(_sample(out, 2, "middlebury2014")))
    _assert_same_tree(_sample(out, 2, "middlebury2014"), tmp_path / "one")


# --------------------------------------------------------------------------- kill and resume
_RUNNER = """
import signal
import sys
from synth.dataset.run import run_dataset
if __name__ == "__main__":
    # a shell without job control starts background jobs with SIGINT ignored, and Python then
    # installs no KeyboardInterrupt handler; restore it, as for a user pressing Ctrl-C
    signal.signal(signal.SIGINT, signal.default_int_handler)
    run_dataset(sys.argv[1], out=sys.argv[2], workers=int(sys.argv[3]), progress=False)
"""


def _complete(out: Path) -> list[str]:
    parent = out / "MiddEval3" / "trainingF"
    return sorted(p.name for p in parent.iterdir() if p.is_dir() and p.name.isdigit()) \
        if parent.exists() else []


def _recorded(out: Path) -> int:
    """How many samples have their completion record (written after their folder's rename)."""
    records = out / "records"
    return sum(1 for _ in records.glob("*.json")) if records.exists() else 0


def _interrupt(config_file: Path, out: Path, tmp_path: Path, *, workers: int, sig: int) -> None:
    script = tmp_path / "runner.py"
    script.write_text(textwrap.dedent(_RUNNER))
    log = tmp_path / "runner.log"
    with open(log, "wb") as sink:
        proc = subprocess.Popen([sys.executable, str(script), str(config_file), str(out),
                                 str(workers)], stdout=sink, stderr=sink)
    try:
        deadline = time.monotonic() + 60
        # three records, not three folders: a folder renamed into place whose record the
        # signal then cut off is rendered again by the restart (not skipped)
        while _recorded(out) < 3:
            assert proc.poll() is None, log.read_text()[-2000:]
            assert time.monotonic() < deadline, "no sample appeared within 60 s"
            time.sleep(0.005)
        os.kill(proc.pid, sig)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode != 0
    done = _complete(out)
    assert 3 <= len(done) < 12, done  # killed mid-way
    for name in done:  # every sample directory present is complete
        assert {p.name for p in (out / "MiddEval3" / "trainingF" / name).iterdir()} == MIDDLEBURY_FILES


@pytest.mark.gl
@pytest.mark.slow
def test_sigkill_then_restart_gives_the_uninterrupted_bytes(reference, config_file, tmp_path):
    out = tmp_path / "ds"
    _interrupt(config_file, out, tmp_path, workers=1, sig=signal.SIGKILL)
    run = run_dataset(config_file, out=out, workers=1, progress=False)
    assert run.skipped >= 3 and run.rendered + run.skipped == 12
    _assert_same_tree(reference, out)


@pytest.mark.gl
@pytest.mark.slow
def test_sigint_with_two_workers_then_restart(reference, config_file, tmp_path):
    out = tmp_path / "ds"
    _interrupt(config_file, out, tmp_path, workers=2, sig=signal.SIGINT)
    run_dataset(config_file, out=out, workers=1, progress=False)
    _assert_same_tree(reference, out)
    assert not [p for p in out.iterdir() if ".tmp-" in p.name]


@pytest.mark.gl
def test_edge_density_config_reaches_its_targets(tmp_path, renderer):
    text = CONFIG.replace("count = 12", "count = 4").replace("width = 48", "width = 64").replace(
        "height = 32", "height = 48").replace(
        'base = {choice = ["fronto_plane", "boxes", "flying"]}', 'base = "fronto_plane"').replace(
        'texture = {choice = ["preset", "noise"]}', 'texture = "noise"\n'
        "edge_density = {uniform = [0.05, 0.3]}").replace("occluders = {uniform = [0, 2]}",
                                                          "occluders = 0")
    run_dataset(loads_config(text), out=tmp_path / "ds", progress=False)
    for r in read_manifest(tmp_path / "ds"):
        target = r["params"]["scene.edge_density"]
        assert abs(r["stats"]["edge_density"] - target) <= 0.02
        assert r["stats"]["edge_search_probes"] >= 1


@pytest.mark.gl
def test_the_edge_statistic_reuses_the_search_measurement(tmp_path, renderer, monkeypatch):
    import synth.dataset.sample as dataset
    from synth.appearance.texture_control import edge_density

    text = CONFIG.replace("count = 12", "count = 2").replace("width = 48", "width = 64").replace(
        "height = 32", "height = 48").replace(
        'base = {choice = ["fronto_plane", "boxes", "flying"]}', 'base = "fronto_plane"').replace(
        'texture = {choice = ["preset", "noise"]}', 'texture = "noise"\n'
        "edge_density = {uniform = [0.1, 0.2]}")
    cfg = loads_config(text)
    calls = []
    monkeypatch.setattr(dataset, "edge_density", lambda img: calls.append(1) or edge_density(img))
    record = dataset.produce_sample(cfg, 0, renderer, tmp_path / "s", "middlebury")
    assert calls == []  # the search rendered this left view already: no second Canny
    assert (tmp_path / "s" / "sample.json").is_file()
    plain = loads_config(text.replace("edge_density = {uniform = [0.1, 0.2]}", ""))
    dataset.produce_sample(plain, 0, renderer, tmp_path / "p", "middlebury")
    assert calls == [1]  # without a search the statistic is measured
    assert record["stats"]["edge_search_probes"] >= 1


# --------------------------------------------------------------------------- resume that verifies
def _copy(src: Path, dst: Path) -> Path:
    import shutil

    shutil.copytree(src, dst)
    return dst


def _damage(out: Path) -> None:
    """An emptied folder (3), a truncated image (5), no record (8), a damaged sample.json (9)."""
    for f in _sample(out, 3).iterdir():
        f.unlink()  # an emptied sample folder: used to count as done, a hole in the manifest
    image = _sample(out, 5) / "im0.png"
    image.write_bytes(image.read_bytes()[:1000])  # a truncated image: used to be kept
    _record(out, 8).unlink()  # no completion record: not done
    (_sample(out, 9) / "sample.json").write_text('{"index": 9, "seed": ')  # cut by an editor


@pytest.mark.gl
def test_resume_renders_again_an_emptied_folder_and_a_truncated_file(reference, config_file,
                                                                      tmp_path):
    from synth.dataset.storage.integrity import verify_dataset

    out = _copy(reference, tmp_path / "ds")
    _damage(out)
    problems = verify_dataset(out)
    size = (_sample(reference, 5) / "im0.png").stat().st_size
    assert problems[:2] == [
        "MiddEval3/trainingF/000003/calib.txt: missing (listed in records/000003.json)",
        "MiddEval3/trainingF/000003/disp0GT.pfm: missing (listed in records/000003.json)",
    ], problems
    assert f"MiddEval3/trainingF/000005/im0.png: 1000 bytes, its record says {size} bytes " \
        "(truncated or replaced)" in problems
    assert "000008: no completion record (records/000008.json); the sample is incomplete" \
        in problems
    run = run_dataset(config_file, out=out, workers=1, progress=False)
    assert (run.rendered, run.skipped) == (4, 8)
    record_size = len((_sample(reference, 9) / "sample.json").read_bytes())
    assert run.damaged == (
        (3, ("MiddEval3/trainingF/000003: empty (the 10 files its record lists there are "
             "missing)",)),
        (5, (f"MiddEval3/trainingF/000005/im0.png: 1000 bytes, its record says {size} bytes "
             "(truncated or replaced)",)),
        (8, ("no completion record (records/000008.json); the sample is incomplete",)),
        (9, (f"MiddEval3/trainingF/000009/sample.json: 21 bytes, its record says {record_size} "
             "bytes (truncated or replaced)",)))
    _assert_same_tree(reference, out)
    assert verify_dataset(out, count=12) == []
    assert run_dataset(config_file, out=out, progress=False).damaged == ()


@pytest.mark.gl
def test_the_dataset_command_says_which_samples_it_repaired_and_why(reference, config_file,
                                                                    tmp_path):
    from click.testing import CliRunner

    from synth.cli import main as cli

    out = _copy(reference, tmp_path / "ds")
    _damage(out)
    image = (_sample(reference, 5) / "im0.png").stat().st_size
    result = CliRunner().invoke(cli, ["dataset", str(config_file), "--out", str(out)])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[-5].startswith(
        f"12 samples in {out}: 4 rendered (4 found damaged or incomplete and rendered again, "
        "below), 8 already there, "), result.output
    assert lines[-4:] == [
        "  000003 rendered again: MiddEval3/trainingF/000003: empty (the 10 files its record "
        "lists there are missing)",
        f"  000005 rendered again: MiddEval3/trainingF/000005/im0.png: 1000 bytes, its record "
        f"says {image} bytes (truncated or replaced)",
        "  000008 rendered again: no completion record (records/000008.json); the sample is "
        "incomplete",
        "  000009 rendered again: MiddEval3/trainingF/000009/sample.json: 21 bytes, its record "
        f"says {len((_sample(reference, 9) / 'sample.json').read_bytes())} bytes (truncated or "
        "replaced)"]
    _assert_same_tree(reference, out)


@pytest.mark.gl
def test_same_size_corruption_is_left_to_verify(reference, config_file, tmp_path):
    """Resume checks sizes only (cheap); --verify checks every SHA-256 and reports the rest."""
    from synth.dataset.storage.integrity import verify_dataset

    out = _copy(reference, tmp_path / "ds")
    disp = _sample(out, 2) / "disp0GT.pfm"
    data = bytearray(disp.read_bytes())
    data[-1] ^= 0xFF
    disp.write_bytes(bytes(data))
    (_sample(out, 4) / "notes.txt").write_text("mine")
    (out / "stray.bin").write_bytes(b"x")
    (out / ".000007.tmp-123").mkdir()
    import shutil

    shutil.rmtree(_sample(out, 6))
    _record(out, 6).unlink()
    assert run_dataset(config_file, out=out, count=3, progress=False).rendered == 0
    assert verify_dataset(out, checksums=False) == [
        "000006: missing (a hole: the dataset has samples after it)",
        "MiddEval3/trainingF/000004/notes.txt: extra file (no sample's record lists it)",
        "stray.bin: extra file"]  # the stale .tmp dir was removed by the run
    problems = verify_dataset(out, count=14)
    assert problems == [
        "MiddEval3/trainingF/000002/disp0GT.pfm: SHA-256 differs from its record (corrupt)",
        "000006: missing (count is 14)", "000012: missing (count is 14)",
        "000013: missing (count is 14)",
        "MiddEval3/trainingF/000004/notes.txt: extra file (no sample's record lists it)",
        "stray.bin: extra file"]
    from click.testing import CliRunner

    from synth.cli import main as cli

    result = CliRunner().invoke(cli, ["dataset", "--verify", str(out), "--count", "14"])
    assert result.exit_code == 1
    assert result.output.splitlines() == [*problems, f"{out}: 6 problem(s)"]
    ok = CliRunner().invoke(cli, ["dataset", "--verify", str(reference)])
    assert ok.exit_code == 0 and ok.output.endswith("complete, every file matches its record\n")
    (out / "manifest.jsonl").write_text("")
    assert verify_dataset(out, checksums=False)[-1] == (
        "manifest.jsonl: does not match the samples' sample.json (rerun the dataset command to "
        "rewrite it)")


@pytest.mark.gl
def test_verify_reports_a_sample_json_that_is_not_json_instead_of_stopping(reference, tmp_path):
    from synth.dataset.storage.integrity import verify_dataset

    out = _copy(reference, tmp_path / "ds")
    record = _sample(out, 9) / "sample.json"
    size = record.stat().st_size
    record.write_text('{"index": 9, "seed": ')
    problems = verify_dataset(out)
    assert problems[0] == (f"MiddEval3/trainingF/000009/sample.json: 21 bytes, its record says "
                           f"{size} bytes (truncated or replaced)")
    assert problems[1].startswith(f"manifest.jsonl, manifest.csv: not checked ({record}: not a "
                                  "sample record: invalid JSON"), problems
    assert len(problems) == 2


_TORN = """
import fnmatch, os, sys
from synth.dataset.run import run_dataset
real = os.replace
def replace(src, dst, *args, **kwargs):
    real(src, dst, *args, **kwargs)
    if fnmatch.fnmatch(str(dst), sys.argv[4]):
        os._exit(3)  # die between two files of one sample, as a kill -9 would
os.replace = replace
if __name__ == "__main__":
    run_dataset(sys.argv[1], out=sys.argv[2], fmt=sys.argv[3], count=4, progress=False)
"""


@pytest.mark.gl
@pytest.mark.parametrize("fmt, die_after, torn", [
    ("middlebury", "*/.000002.tmp-*/disp0GT.pfm", 2),  # the 3rd file of sample 2, in its temp dir
    ("middlebury2014", "*/.000001.tmp-*/disp0.pfm", 1),
    ("kitti", "*/ds/training/image_3/000001_10.png", 1),  # sample 1: a file moved, others to go
])
def test_a_torn_sample_is_rendered_again_with_the_same_bytes(config_file, tmp_path, fmt,
                                                             die_after, torn):
    clean = tmp_path / "clean"
    run_dataset(config_file, out=clean, fmt=fmt, count=4, progress=False)
    out = tmp_path / "ds"
    script = tmp_path / "torn.py"
    script.write_text(_TORN)
    died = subprocess.run([sys.executable, str(script), str(config_file), str(out), fmt,
                           die_after], capture_output=True, text=True, timeout=300)
    assert died.returncode == 3, died.stderr[-2000:]
    assert not (out / "manifest.jsonl").exists()  # it died mid-run
    run = run_dataset(config_file, out=out, fmt=fmt, count=4, progress=False)
    assert (run.rendered, run.skipped) == (4 - torn, torn)
    _assert_same_tree(clean, out)


@pytest.mark.gl
def test_kitti_records_list_the_images_outside_the_sample_folder(config_file, tmp_path,
                                                                  renderer):
    from synth.dataset.storage.integrity import verify_dataset

    out = tmp_path / "kitti"
    run_dataset(config_file, out=out, count=2, fmt="kitti", progress=False)
    record = json.loads(_record(out, 1).read_text())
    assert sorted(record["files"]) == sorted(
        [f"training/{s}/000001_10.png"
         for s in ("image_2", "image_3", "disp_occ_0", "disp_noc_0", "obj_map")]
        + ["training/calib_cam_to_cam/000001.txt", "training/samples/000001/scene.json",
           "training/samples/000001/sample.json"])
    clean = _tree(out)
    image = out / "training" / "image_3" / "000001_10.png"
    image.write_bytes(image.read_bytes()[:100])
    (out / "training" / "disp_noc_0" / "000009_10.png").write_bytes(b"stray")
    assert verify_dataset(out) == [
        f"training/image_3/000001_10.png: 100 bytes, its record says "
        f"{len(clean['training/image_3/000001_10.png'])} bytes (truncated or replaced)",
        "training/disp_noc_0/000009_10.png: extra file (no sample's record lists it)"]
    (out / "training" / "disp_noc_0" / "000009_10.png").unlink()
    run = run_dataset(config_file, out=out, count=2, fmt="kitti", progress=False)
    assert (run.rendered, run.skipped) == (1, 1)
    assert _tree(out) == clean


# --------------------------------------------------------------------------- layout 1 -> 2
def _to_layout_1(src: Path, dst: Path) -> None:
    """``src`` (layout 2) as stereoforge wrote it before: sample folders at the root, each with
    its completion record ``files.json`` inside."""
    import shutil

    shutil.copytree(src, dst)
    for d in sorted((dst / "MiddEval3" / "trainingF").iterdir()):
        os.replace(d, dst / d.name)
        record = json.loads((dst / RECORDS / f"{d.name}.json").read_text())  # files.json inside
        record["files"] = {k.removeprefix("MiddEval3/trainingF/"): v
                           for k, v in record["files"].items()}
        (dst / d.name / "files.json").write_text(json.dumps(record, indent=2, sort_keys=True)
                                                 + "\n")
    shutil.rmtree(dst / "MiddEval3")
    shutil.rmtree(dst / RECORDS)
    header = json.loads((dst / "dataset.json").read_text())
    del header["layout"]
    (dst / "dataset.json").write_text(json.dumps(header, indent=2, sort_keys=True) + "\n")


@pytest.mark.gl
def test_a_layout_1_dataset_is_refused_then_upgraded_to_the_same_bytes(reference, config_file,
                                                                         tmp_path):
    from click.testing import CliRunner

    from synth.cli import main
    from synth.dataset.storage.layout import upgrade_dataset

    old = tmp_path / "old"
    _to_layout_1(reference, old)
    for call in (lambda: run_dataset(config_file, out=old, progress=False),
                 lambda: read_manifest(old),
                 lambda: render_from_manifest(old, 1, out=tmp_path / "one")):
        with pytest.raises(DatasetError, match=rf"previous layout .*`stereoforge dataset "
                                               rf"--upgrade {old}`"):
            call()
    refused = CliRunner().invoke(main, ["dataset", str(config_file), "--out", str(old)])
    assert refused.exit_code != 0
    assert refused.output.strip().splitlines()[-1].startswith("Error: ")
    assert f"stereoforge dataset --upgrade {old}" in refused.output
    assert "Traceback" not in refused.output
    # an upgrade interrupted after moving 5 samples: the rerun finishes it
    (old / "MiddEval3" / "trainingF").mkdir(parents=True)
    for i in range(5):
        os.replace(old / f"{i:06d}", _sample(old, i))
    done = CliRunner().invoke(main, ["dataset", "--upgrade", str(old)])
    assert done.exit_code == 0, done.output
    assert "7 sample folders moved" in done.output
    _assert_same_tree(reference, old)
    assert upgrade_dataset(old) == 0  # idempotent
    again = run_dataset(config_file, out=old, progress=False)
    assert (again.rendered, again.skipped) == (0, 12)
    _assert_same_tree(reference, old)


def test_sample_disparity_range_equals_numpys_masked_reductions():
    """A sample's disp_min/disp_max come from one compiled pass: the floats numpy's masked
    min/max give (the values written into every sample.json)."""
    import numpy as np

    from synth._util.ranges import finite_range

    rng = np.random.default_rng(3)
    for trial in range(30):
        shape = (int(rng.integers(1, 60)), int(rng.integers(1, 60)))
        disp = (rng.normal(40.0, 30.0, shape)).astype(np.float32)
        for value, share in ((np.inf, 0.2), (-np.inf, 0.05), (np.nan, 0.05)):
            disp[rng.random(shape) < share * (trial % 3)] = value
        if trial == 5:
            disp[:] = np.inf  # no ground truth at all
        lo, hi = finite_range(disp)
        finite = np.isfinite(disp)
        if finite.any():
            assert lo == np.min(disp, where=finite, initial=np.inf)
            assert hi == np.max(disp, where=finite, initial=-np.inf)
        else:
            assert (lo, hi) == (np.inf, -np.inf)


def test_calib_range_kernel_equals_numpys_masked_reductions():
    """calib.txt's bounds come from one compiled pass over both maps: the floats numpy's masked
    min/max give, over non-contiguous and float64 maps too."""
    import numpy as np

    from synth._util.ranges import finite_range

    rng = np.random.default_rng(4)
    for trial in range(30):
        shape = (int(rng.integers(1, 50)), int(rng.integers(1, 50)))
        maps = [rng.normal(30.0, 40.0, shape).astype(np.float32 if trial % 4 else np.float64)
                for _ in range(2)]
        for d in maps:
            for value, share in ((np.inf, 0.3), (-np.inf, 0.05), (np.nan, 0.1)):
                d[rng.random(shape) < share * (trial % 3)] = value
        if trial == 7:
            maps[0][:] = np.inf  # one map without ground truth
        if trial == 8:
            maps[0][:], maps[1][:] = np.nan, np.inf  # none at all
        views = [maps[0][:, ::-1], maps[1].T] if trial % 5 == 0 else maps
        want_lo, want_hi = np.inf, -np.inf
        for d in views:
            finite = np.isfinite(d)
            want_lo = min(want_lo, float(np.min(d, where=finite, initial=np.inf)))
            want_hi = max(want_hi, float(np.max(d, where=finite, initial=-np.inf)))
        assert finite_range(*views) == (want_lo, want_hi)
