"""Datasets from elsewhere are untrusted: every class of fault found by trying damaged and
hostile copies, one test each, through the command line as a user meets it (one ``Error:`` line,
the right exit status, no hang, nothing read outside the dataset)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from matcher.io import encode_png, write_pfm
from stereoforge.errors import DatasetError
from synth.cli import main
from synth.dataset.config.parse import loads_config
from synth.dataset.run import run_dataset

CLI = [sys.executable, "-c", "from synth.cli import main; main()"]
CONFIG = """\
name = "untrusted"
seed = 4
count = 2

[rig]
width = 32
height = 24

[scene]
base = "flying"
"""
pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def trees(tmp_path_factory, renderer) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("trees")
    out = {}
    for name in ("middlebury", "sceneflow", "crestereo", "fsd"):
        out[name] = base / name
        run_dataset(loads_config(CONFIG), out=out[name], fmt=name, progress=False)
    return out


def _copy(trees, name, tmp_path) -> Path:
    root = tmp_path / name
    shutil.copytree(trees[name], root)
    return root


def _cli(args, timeout=120, **kw):
    return subprocess.run(CLI + args, capture_output=True, text=True, timeout=timeout, **kw)


def _one_error(run, status=2) -> str:
    errors = [x for x in run.stderr.splitlines() if x.startswith("Error:")]
    assert run.returncode == status and len(errors) == 1, (run.returncode, run.stderr)
    assert "Traceback" not in run.stderr and "libpng" not in run.stderr, run.stderr
    return errors[0]


def _sf_file(root: Path, kind: str, view: str = "left") -> Path:
    ext = "pfm" if kind == "disparity" else "png"
    return root / f"SceneFlow/FlyingThings3D/{kind}/TRAIN/A/0000/{view}/0000.{ext}"


# --------------------------------------------------------------------------- 1. no hang
def test_a_named_pipe_in_a_dataset_is_refused_without_blocking(trees, tmp_path):
    root = _copy(trees, "sceneflow", tmp_path)
    pipe = _sf_file(root, "disparity")
    pipe.unlink()
    os.mkfifo(pipe)
    for args in (["eval-dataset", str(root), "--matcher", "ct:3"],
                 ["train", str(root), "--out", str(tmp_path / "m.pt"), "--steps", "1",
                  "--workers", "0", "--device", "cpu", "--crop", "8"]):
        line = _one_error(_cli(args, timeout=60))
        assert "is a named pipe (FIFO), not a regular file" in line and str(pipe) in line
    run = _cli(["dataset", "--verify", str(root)], timeout=60)
    assert run.returncode == 1 and "not a regular file" in run.stdout, run.stdout
    with pytest.raises(DatasetError, match="named pipe"):
        from synth import StereoDataset

        StereoDataset(root)[0]
    (root / "samples" / "000001" / "scene.json").unlink()
    os.mkfifo(root / "samples" / "000001" / "scene.json")
    line = _one_error(_cli(["eval-dataset", str(root), "--matcher", "ct:3"], timeout=60))
    assert "named pipe" in line


# --------------------------------------------------------------------------- 2. confinement
def test_a_record_naming_files_outside_the_dataset_is_not_read(trees, tmp_path):
    root = _copy(trees, "middlebury", tmp_path)
    secret = tmp_path / "secret.txt"
    secret.write_text("private\n")
    record = root / "records" / "000000.json"
    doc = json.loads(record.read_text())
    doc["files"]["/dev/zero"] = {"bytes": 1, "sha256": "0" * 64}
    doc["files"][f"../{secret.name}"] = {"bytes": 8, "sha256": "0" * 64}
    record.write_text(json.dumps(doc))
    start = time.monotonic()
    run = _cli(["dataset", "--verify", str(root)], timeout=60)
    assert time.monotonic() - start < 60 and run.returncode == 1
    assert "lists '/dev/zero', a path outside the dataset" in run.stdout
    assert f"lists '../{secret.name}', a path outside the dataset" in run.stdout
    assert "bytes, its record says" not in run.stdout  # nothing outside was stat'ed
    # a resume renders the sample again instead of describing the outside file
    resumed = run_dataset(loads_config(CONFIG), out=root, progress=False)
    assert resumed.rendered == 1 and resumed.damaged[0][0] == 0
    assert not any("secret" in p or "zero" in p for p in resumed.damaged[0][1] if "bytes" in p)


def test_a_link_out_of_the_tree_is_refused_by_every_reader(trees, tmp_path):
    root = _copy(trees, "crestereo", tmp_path)
    secret = tmp_path / "secret.png"
    secret.write_bytes(encode_png(np.zeros((24, 32, 3), np.uint8)))
    left = next(root.glob("CREStereo/*/000000_left.jpg"))
    left.unlink()
    left.symlink_to(secret)
    line = _one_error(_cli(["validate", "ct:3", "--axes", "noise", "--against", "",
                            "--skip-battery", "--out", str(tmp_path / "v"), "--real",
                            f"crestereo:{root}"], timeout=300))
    assert f"a symbolic link to {secret}, outside" in line
    run = _cli(["dataset", "--verify", str(root)], timeout=60)
    assert "a link to a file outside the dataset" in run.stdout


# --------------------------------------------------------------------------- 3./4. shapes
@pytest.mark.parametrize("layout, damage", [
    ("sceneflow", "left disparity"), ("sceneflow", "right disparity"),
    ("crestereo", "left disparity"), ("fsd", "left disparity"), ("sceneflow", "right view"),
    ("sceneflow", "colour disparity")])
def test_arrays_of_a_sample_that_disagree_are_one_error_naming_the_file(trees, tmp_path, layout,
                                                                          damage):
    from matcher.io import encode_crestereo_disparity, encode_fsd_disparity

    root = _copy(trees, layout, tmp_path)
    small = np.ones((10, 12), np.float32)
    if layout == "sceneflow":
        view = "right" if damage.startswith("right") else "left"
        path = _sf_file(root, "frames_finalpass" if damage == "right view" else "disparity",
                        view)
        if damage == "right view":
            path.write_bytes(encode_png(np.zeros((24, 20, 3), np.uint8)))  # narrower
        else:
            write_pfm(path, np.ones((24, 32, 3), np.float32) if damage.startswith("colour")
                      else small)
    elif layout == "crestereo":
        path = next(root.glob("CREStereo/*/000000_left.disp.png"))
        path.write_bytes(encode_crestereo_disparity(small))
    else:
        path = next(root.glob("FSD/*/dataset/data/left/disparity/0000.png"))
        path.write_bytes(encode_fsd_disparity(small))
    line = _one_error(_cli(["eval-dataset", str(root), "--matcher", "ct:3"]))
    assert str(path) in line and "sample 0" in line, line
    if damage == "colour disparity":
        assert "has 3 channels" in line
    else:
        assert "must be one size" in line and ("(10, 12)" in line or "(24, 20, 3)" in line)
    from synth import StereoDataset

    with pytest.raises(DatasetError, match="sample 0"):
        StereoDataset(root)[0]


def test_stereo_dataset_keeps_its_documented_shapes(trees, tmp_path):
    from synth import StereoDataset

    root = _copy(trees, "sceneflow", tmp_path)
    grey = np.full((24, 32), 77, np.uint8)
    _sf_file(root, "frames_finalpass").write_bytes(encode_png(grey))  # a grey left view
    item = StereoDataset(root)[0]
    assert item["left"].shape == (24, 32, 3) and (item["left"] == 77).all()
    assert item["right"].shape == (24, 32, 3) and item["disp"].shape == (24, 32)
    (root / "samples" / "000001" / "scene.json").write_text('{"rig": {"fx": 1}}')
    with pytest.raises(DatasetError, match="the rig has no number 'fy'"):
        StereoDataset(root)[1]
    (root / "samples" / "000001" / "scene.json").write_text("{not json")
    with pytest.raises(DatasetError, match=r"scene\.json: not a scene record: invalid JSON"):
        StereoDataset(root)[1]


def test_a_scene_record_without_a_rig_is_named(trees, tmp_path):
    root = _copy(trees, "middlebury", tmp_path)
    path = root / "MiddEval3" / "trainingF" / "000000" / "scene.json"
    doc = json.loads(path.read_text())
    doc.pop("rig")
    path.write_text(json.dumps(doc))
    line = _one_error(_cli(["eval-dataset", str(root), "--matcher", "ct:3"]))
    assert f"{path}: not a scene record: the key 'rig' is missing" in line


def test_a_killed_worker_is_an_environment_error(renderer, tmp_path):
    """A pool worker killed mid-run (as the OOM killer does): exit 1 with the fix, not 'a bug in
    stereoforge'."""
    script = tmp_path / "kill_worker.py"
    script.write_text(
        "import os, signal, sys\n"
        "from synth.dataset.engine.tasks import WorkerLost, run_tasks\n"
        "class Killer:\n"
        "    width, height, backend = 16, 16, 'auto'\n"
        "    def __call__(self, index, renderer):\n"
        "        if index == 1:\n"
        "            os.kill(os.getpid(), signal.SIGKILL)\n"
        "        return {}\n"
        "try:\n"
        "    list(run_tasks(Killer(), range(4), workers=2))\n"
        "except WorkerLost as exc:\n"
        "    print('WorkerLost', exc)\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), *sys.path])}
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=120, env=env, cwd=tmp_path)
    assert run.stdout.startswith("WorkerLost a worker process died"), (run.stdout, run.stderr)
    from synth.cli.errors import describe_error
    from synth.dataset.engine.tasks import WorkerLost

    message, status = describe_error(WorkerLost("a worker process died"))
    assert status == 1 and "a bug" not in message


# --------------------------------------------------------------------------- 5. messages
def test_the_vague_messages_name_the_file_and_the_fix(trees, tmp_path):
    runner = CliRunner()
    # a FIFO model file, a model path that is a folder
    os.mkfifo(tmp_path / "pipe.pt")
    (tmp_path / "folder.pt").mkdir()
    left = tmp_path / "l.png"
    left.write_bytes(encode_png(np.zeros((8, 16), np.uint8)))
    for model, words in ((tmp_path / "pipe.pt", "is a named pipe (FIFO)"),
                         (tmp_path / "folder.pt", "is a folder, not a regular file")):
        r = runner.invoke(main, ["match", str(left), str(left), "--matcher", f"learned:{model}",
                                 "--max-disp", "4", "--out", str(tmp_path / "d.pfm")])
        assert r.exit_code == 2 and words in r.output and "does not exist" not in r.output, \
            r.output
    # a checkpoint path that is a folder: neither "start without --resume" nor "add --resume"
    (tmp_path / "m.pt.ckpt").mkdir()
    r = _cli(["train", str(trees["middlebury"]), "--out", str(tmp_path / "m.pt"), "--steps",
              "1", "--device", "cpu"])
    line = _one_error(r)
    assert "m.pt.ckpt is not a regular file" in line and "--resume" not in line
    # --out under a file
    (tmp_path / "afile").write_text("x")
    line = _one_error(_cli(["train", str(trees["middlebury"]), "--out",
                            str(tmp_path / "afile" / "m.pt"), "--steps", "1"]))
    assert "afile is a file, not a folder" in line
    # ct: with an empty window is refused, not run as ct:9
    r = runner.invoke(main, ["eval-dataset", str(trees["middlebury"]), "--matcher", "ct:"])
    assert r.exit_code == 2 and "no window after ':'" in r.output, r.output
    # golden check --root: missing, empty, a dataset
    (tmp_path / "empty").mkdir()
    for root, words in ((tmp_path / "absent", "does not exist"), (tmp_path / "empty", "is empty"),
                        (trees["middlebury"], "holds no manifest.json")):
        r = runner.invoke(main, ["golden", "check", "--root", str(root), "--no-render"])
        assert r.exit_code == 2 and words in r.output, r.output


def test_a_2014_scene_without_its_ground_truth_names_both_names(tmp_path, renderer):
    root = tmp_path / "m14"
    run_dataset(loads_config(CONFIG), out=root, fmt="middlebury2014", progress=False)
    (root / "2014" / "000000" / "disp0.pfm").unlink()
    line = _one_error(_cli(["eval-dataset", str(root), "--matcher", "ct:3"]))
    assert "no left ground truth (disp0GT.pfm or disp0.pfm)" in line
    assert "No such file" not in line


def test_a_cut_png_gives_our_line_and_no_libpng_noise(tmp_path):
    from matcher.io import read_image
    from stereoforge.errors import FormatError

    good = encode_png(np.random.default_rng(0).integers(0, 255, (40, 60, 3), np.uint8))
    (tmp_path / "cut.png").write_bytes(good[: len(good) // 2])
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data))
    (tmp_path / "wide.png").write_bytes(  # a 30,000-pixel-wide header over a few bytes of data
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 30000, 10, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(b"\0" * 100)) + chunk(b"IEND", b""))
    for name, words in (("cut.png", "a PNG cut short"),
                        ("wide.png", "announces 30000x10 pixels")):
        with pytest.raises(FormatError, match=words):
            read_image(tmp_path / name)
        line = _one_error(_cli(["eval", str(tmp_path / name), str(tmp_path / name),
                                "--gt-divisor", "1"]))
        assert words in line


# --------------------------------------------------------------------------- 6. before work
def test_a_bad_photograph_source_is_refused_when_the_config_is_read(tmp_path):
    (tmp_path / "none").mkdir()
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "x.png").write_text("not an image")
    for source, words in (("none", "holds no image file"), ("junk", "is not an image Pillow")):
        config = tmp_path / f"{source}.toml"
        config.write_text(CONFIG + 'object_texture = {choice = ["image"]}\n'
                          f'object_image = {{choice = ["{tmp_path / source}"]}}\n')
        line = _one_error(_cli(["dataset", str(config), "--out", str(tmp_path / "out")]))
        assert words in line and "object_image" in line
        assert not (tmp_path / "out").exists()


def test_bench_transfer_refuses_an_aggregate_beyond_the_limit_at_once(tmp_path):
    start = time.monotonic()
    line = _one_error(_cli(["bench", "transfer", "--aggregate", "513", "--no-ceiling", "--out",
                            str(tmp_path / "o")]))
    assert "--aggregate: expected 1 (none) or an odd box side 3..511, got 513" in line
    assert time.monotonic() - start < 60 and not (tmp_path / "o").exists()


# --------------------------------------------------------------------------- 7. signals
def _terminal_sigint():
    """Ctrl-C as a terminal delivers it: a job started in the background of a script (``cmd &``,
    ``nohup``) inherits SIGINT ignored, and Python then never raises KeyboardInterrupt."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("to", ["group", "main"])
def test_ctrl_c_during_dataset_is_exit_130_with_one_line(tmp_path, renderer, to):
    """Ctrl-C at a terminal reaches the whole process group (``group``: the workers too); a
    ``kill -INT`` reaches the main process alone (``main``). Either way the run ends soon, with
    one line and status 130, and what it kept is whole."""
    proc = subprocess.Popen(CLI + ["dataset", "planes", "--count", "5000", "--size", "320x240",
                                   "--out", str(tmp_path / "d"), "--workers", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=_terminal_sigint)
    try:
        deadline = time.monotonic() + 120
        while not list((tmp_path / "d" / "records").glob("*.json")) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert proc.poll() is None, "the dataset ended before a sample was recorded"
        if to == "group":
            os.killpg(proc.pid, signal.SIGINT)
        else:
            proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:  # a hang fails this test alone: nothing is left running
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    lines = [x for x in err.splitlines() if x.startswith("Error:")]
    assert proc.returncode == 130, err
    assert len(lines) == 1 and "interrupted (Ctrl-C)" in lines[0] and "Aborted!" not in err
    run = _cli(["dataset", "--verify", str(tmp_path / "d")])
    assert run.returncode == 0, run.stdout  # what was kept is whole


def test_a_full_disk_is_the_machines_error_not_a_sample_to_reproduce(tmp_path, monkeypatch,
                                                                      renderer):
    import errno

    from synth.cli.errors import describe_error
    from synth.dataset import sample as sample_module

    def full(*_args, **_kw):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "d" / "im0.png"))

    monkeypatch.setattr(sample_module, "produce_sample", full)
    with pytest.raises(OSError) as info:
        run_dataset(loads_config(CONFIG), out=tmp_path / "d", progress=False)
    message, status = describe_error(info.value)
    assert status == 1 and "free some space or choose another --out" in message
    assert "render_from_manifest" not in message
