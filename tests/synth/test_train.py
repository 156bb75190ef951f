"""stereoforge train: learning lowers the loss and beats the untrained network, resume after a
kill or Ctrl-C equals the uninterrupted run, the model file, bad input, and torch's DataLoader
with worker processes over StereoDataset of every layout."""

from __future__ import annotations

import csv
import importlib.util
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

if importlib.util.find_spec("torch") is None:  # the extra 'learn'
    if os.environ.get("STEREOFORGE_REQUIRE_TORCH", "") not in ("", "0"):
        raise RuntimeError("torch is not installed and STEREOFORGE_REQUIRE_TORCH=1 forbids skipping")
    pytest.skip("torch is not installed (pip install 'stereoforge[learn]')", allow_module_level=True)

import torch  # noqa: E402
from torch.utils.data import DataLoader  # noqa: E402

from matcher import evaluate, resolve_matcher  # noqa: E402
from matcher.learned import Architecture, PatchNet, load_model, match_learned  # noqa: E402
from matcher.learned.model import LearnedModel  # noqa: E402
from synth import StereoDataset  # noqa: E402
from synth.dataset.config.parse import loads_config  # noqa: E402
from synth.dataset.run import run_dataset  # noqa: E402
from synth.jobs.train import PatchBatches, open_sources  # noqa: E402

CONFIG = """\
name = "train-test"
seed = 5
count = 14

[rig]
width = 128
height = 96

[scene]
base = "flying"
occluders = {uniform = [1, 3]}

[photometric]
noise_sigma = {uniform = [0.5, 1.5]}
"""
CLI = [sys.executable, "-c", "from synth.cli import main; main()"]
pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def data(tmp_path_factory, renderer) -> Path:
    out = tmp_path_factory.mktemp("train") / "flying"
    run_dataset(loads_config(CONFIG), out=out, progress=False)
    return out


def _bad3(model: LearnedModel, sample: dict) -> float:
    est = match_learned(sample["left"], sample["right"], model, max_disparity=48, aggregate=5)
    return float(evaluate(est.disparity, sample["disp"], delta=3.0, region="all").pobmp)


def test_training_lowers_the_loss_and_beats_the_untrained_network(data, tmp_path):
    # every training in this module runs as the CLI does, in a process of its own: the first
    # torch.use_deterministic_algorithms imports torch._inductor, which crashes a process that
    # has Mesa's llvmpipe loaded (this one renders)
    out = tmp_path / "m.pt"
    r = _cli(["train", str(data), "--out", str(out), "--steps", "200", "--crops", "4",
              "--workers", "0", "--device", "cpu"], check=True)
    assert "trained 200 steps" in r.stdout
    import csv

    rows = list(csv.DictReader((tmp_path / "m.csv").read_text().splitlines()))
    assert [int(r["step_to"]) for r in rows] == [100, 200]
    assert float(rows[-1]["train_loss"]) < float(rows[0]["train_loss"])
    assert all(float(r["val_loss"]) > 0 for r in rows)  # measured on the validation split
    torch.manual_seed(0)  # the untrained network: the same initialisation, no step
    untrained = LearnedModel(net=PatchNet(Architecture()).eval())
    trained = load_model(out)
    val = StereoDataset(data, split="val")
    scores = [(_bad3(untrained, val[i]), _bad3(trained, val[i])) for i in range(len(val))]
    assert all(after < before for before, after in scores), scores
    header = trained.header
    assert header["training"]["steps"] == 200 and header["training"]["seed"] == 0
    assert header["training"]["sources"][0]["name"] == "train-test"
    import json

    assert header["training"]["sources"][0]["hash"] == json.loads(
        (data / "dataset.json").read_text())["config_hash"]
    assert header["inference"]["aggregate"] in (1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21)


def test_batches_are_a_function_of_seed_and_step_only(data):
    sources = open_sources([str(data)])
    a = PatchBatches(sources, seed=3, radius=4, crops=6)
    b = PatchBatches(sources, seed=3, radius=4, crops=6)
    b[9]  # another order of requests and a warm cache change nothing
    for k in (9, 0, 4):
        for ca, cb in zip(a[k], b[k], strict=True):
            for f in ("left", "right", "ys", "xs", "x_pos", "x_neg"):
                np.testing.assert_array_equal(getattr(ca, f), getattr(cb, f))
    other = PatchBatches(sources, seed=4, radius=4, crops=6)
    assert not np.array_equal(a[0][0].left, other[0][0].left)


def test_every_training_pair_is_used_equally(data):
    sources = open_sources([str(data)])
    batches = PatchBatches(sources, seed=1, radius=4, crops=4)
    n = len(batches.pairs)
    counts = np.bincount([batches._pair_number(j) for j in range(5 * n)], minlength=n)
    assert (counts == 5).all()


def _weights(path: Path) -> dict:
    return load_model(path).net.state_dict()


def _cli(args, **kw):
    return subprocess.run(CLI + args, capture_output=True, text=True, **kw)


def _children(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True)
    return [int(p) for p in out.stdout.split()]


@pytest.mark.slow
@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGINT])
def test_resume_after_a_kill_or_ctrl_c_equals_the_uninterrupted_run(data, tmp_path, how):
    args = ["train", str(data), "--steps", "60", "--seed", "2", "--device", "cpu", "--workers",
            "2", "--crops", "8", "--checkpoint-minutes", "0.003"]
    whole = _cli(args + ["--out", str(tmp_path / "whole.pt")], check=True)
    assert "trained 60 steps" in whole.stdout
    out = tmp_path / "cut.pt"
    ckpt = Path(f"{out}.ckpt")
    proc = subprocess.Popen(CLI + args + ["--out", str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not ckpt.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    workers = _children(proc.pid)
    assert proc.poll() is None, "the run ended before it could be interrupted"
    proc.send_signal(how)
    _, err = proc.communicate(timeout=60)
    if how == signal.SIGINT:
        assert proc.returncode == 130
        assert "interrupted (SIGINT) at step" in err and "--resume" in err
        assert "Traceback" not in err
    else:
        assert proc.returncode == -signal.SIGKILL
    assert ckpt.is_file() and not out.exists()
    time.sleep(1.0)
    alive = [p for p in workers if Path(f"/proc/{p}").exists()
             and "zombie" not in Path(f"/proc/{p}/status").read_text().lower()]
    assert alive == [], "worker processes outlived the trainer"
    leftovers = {p.name for p in tmp_path.iterdir() if p.name.startswith(".")
                 or p.suffix in (".tmp", ".lock")}
    if how == signal.SIGINT:  # a clean stop; kill -9 may land in a write and leave its temp
        assert leftovers == set()
    resumed = _cli(args + ["--out", str(out), "--resume"], check=True)
    assert "resuming" in resumed.stderr and "trained 60 steps" in resumed.stdout
    assert not any(p.name.startswith(".") or p.suffix in (".tmp", ".lock")
                   for p in tmp_path.iterdir()), "the resumed run left temporary files"
    a, b = _weights(tmp_path / "whole.pt"), _weights(out)
    assert all(torch.equal(a[k], b[k]) for k in a)
    steps = [line.split(",")[1] for line in out.with_suffix(".csv").read_text().splitlines()[1:]]
    assert steps == ["60"]
    again = _cli(args + ["--out", str(out), "--resume"])
    assert again.returncode == 2 and "is finished" in again.stderr


def test_bad_input_is_one_line(data, tmp_path):
    (tmp_path / "nogt").mkdir()
    from matcher.io import encode_png

    for name in ("im0.png", "im1.png"):
        (tmp_path / "nogt" / name).write_bytes(encode_png(np.zeros((8, 8, 3), np.uint8)))
    cases = [
        ([str(tmp_path / "nogt"), "--out", str(tmp_path / "a.pt"), "--steps", "1"],
         "no ground-truth disparity"),
        ([str(tmp_path / "missing"), "--out", str(tmp_path / "a.pt"), "--steps", "1"],
         "no such folder"),
        ([str(data), "--out", str(tmp_path / "a.pt"), "--steps", "1", "--resume"],
         "no checkpoint"),
        ([str(data), "--out", str(tmp_path / "a.txt"), "--steps", "1"], "a .pt model file"),
        (["middlebury:" + str(tmp_path / "nogt"), "--out", str(tmp_path / "a.pt")],
         "disp0"),
    ]
    for args, words in cases:
        r = _cli(["train", *args])
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2, r.stderr
        assert len(lines) == 1 and lines[0].startswith("Error: ") and words in lines[0], r.stderr
    (tmp_path / "bad.pt").write_bytes(b"\x00" * 64)
    r = _cli(["match", str(data / "MiddEval3/trainingF/000000/im0.png"),
              str(data / "MiddEval3/trainingF/000000/im1.png"), "--out", str(tmp_path / "d.pfm"),
              "--matcher", f"learned:{tmp_path / 'bad.pt'}"])
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert r.stderr.startswith("Error: matcher 'learned:") and "not a readable model file" in r.stderr


def test_an_existing_model_is_not_overwritten_without_asking(data, tmp_path):
    out = tmp_path / "m.pt"
    out.write_bytes(b"keep")
    r = _cli(["train", str(data), "--out", str(out), "--steps", "1"])
    assert r.returncode == 2 and "exists" in r.stderr and "--overwrite" in r.stderr
    assert out.read_bytes() == b"keep"


def test_two_trainers_on_one_model_do_not_mix(data, tmp_path):
    from matcher.io.atomic import claim_output

    out = tmp_path / "m.pt"
    with claim_output(out, [out]):  # another trainer is writing m.pt
        r = _cli(["train", str(data), "--out", str(out), "--steps", "1"])
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and len(lines) == 1, r.stderr
    assert "another process is writing it" in lines[0] and "m.pt.lock" in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_a_trained_model_is_a_matcher_everywhere(data, tmp_path):
    out = tmp_path / "m.pt"
    _cli(["train", str(data), "--out", str(out), "--steps", "5", "--crops", "4", "--workers",
          "0"], check=True)
    m = resolve_matcher(f"learned:{out}")
    s = StereoDataset(data)[0]
    disp = m(s["left"], s["right"], max_disparity=32)
    assert disp.shape == s["disp"].shape and disp.dtype == np.float32
    r = _cli(["match", str(data / "MiddEval3/trainingF/000000/im0.png"),
              str(data / "MiddEval3/trainingF/000000/im1.png"), "--out", str(tmp_path / "d.pfm"),
              "--matcher", f"learned:{out}", "--max-disp", "32"], check=True)
    assert r.stdout.startswith("learned:m D=32:")


@pytest.mark.parametrize("fmt", ["middlebury", "kitti", "middlebury2014", "sceneflow",
                                 "crestereo", "fsd"])
def test_a_torch_dataloader_with_two_workers_reads_stereodataset(renderer, tmp_path, fmt):
    out = tmp_path / fmt
    run_dataset(loads_config(CONFIG), out=out, fmt=fmt, count=4, progress=False)
    data = StereoDataset(out)
    loader = DataLoader(data, batch_size=2, num_workers=2, multiprocessing_context="spawn")
    batches = list(loader)
    assert len(batches) == 2
    first = batches[0]
    assert first["left"].shape == (2, 96, 128, 3) and first["left"].dtype == torch.uint8
    assert first["disp"].dtype == torch.float32 and first["valid"].dtype == torch.bool
    for b, batch in enumerate(batches):
        for j in range(2):
            want = data[2 * b + j]
            np.testing.assert_array_equal(batch["left"][j].numpy(), want["left"])
            np.testing.assert_array_equal(batch["disp"][j].numpy(), want["disp"])
            assert int(batch["index"][j]) == int(want["index"])


def test_the_torch_example_of_docs_learning_trains(data):
    example = Path(__file__).resolve().parents[2] / "docs" / "examples" / "train_torch.py"
    r = subprocess.run([sys.executable, str(example), str(data), "--steps", "20", "--workers",
                        "2"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1].startswith("step 20: loss ")


def _rows(path: Path) -> list[dict]:
    return list(csv.DictReader(path.read_text().splitlines()))


@pytest.mark.slow
@pytest.mark.realdata
def test_bench_transfer_trains_scores_and_draws(tmp_path, dev_data_dir):
    """A tiny run: one config, one seed, no ceiling, Motorcycle only (no Middlebury folder),
    and two real sets of the development scenes scored by their field's metric."""
    config = tmp_path / "tiny.toml"
    config.write_text(CONFIG.replace("count = 14", "count = 4"))
    env = {**os.environ, "STEREOFORGE_MIDDLEBURY": str(tmp_path / "none")}
    out = tmp_path / "bench"
    import shutil

    eth = tmp_path / "eth3d"  # two of the seven scenes: a short run (copies: a tree's files
    for tree in ("two_view_training", "two_view_training_gt"):  # must be inside it)
        for scene in ("delivery_area_1s", "terrace_1s"):
            shutil.copytree(dev_data_dir / "eth3d" / tree / scene, eth / tree / scene)
    r = _cli(["bench", "transfer", "--configs", str(config), "--count", "4", "--minutes", "0.3",
              "--no-ceiling", "--out", str(out), "--real", f"eth3d:{eth}",
              "--real", f"kitti:{dev_data_dir / 'kitti2015'}"], env=env)
    assert r.returncode == 0, r.stderr
    summary = _rows(out / "transfer.csv")
    assert [row["method"] for row in summary] == ["CT-9", "CT-21", "SGBM-5", "learned on tiny"]
    real = _rows(out / "transfer-real.csv")
    assert len(real) == 4 * 3 and {r["metric"] for r in real if r["set"] == "eth3d"} == \
        {"bad1_nonocc"} and {r["metric"] for r in real if r["set"] == "kitti"} == {"d1"}
    for row in summary:  # the set's column is the mean of its scenes' rows
        values = [float(r["value"]) for r in real if r["method"] == row["method"]
                  and r["set"] == "eth3d"]
        assert float(row["eth3d bad1_nonocc"]) == pytest.approx(np.mean(values), abs=0.006)
        assert 0 <= float(row["kitti d1"]) <= 100
    scenes = _rows(out / "transfer-scenes.csv")
    assert {row["scene"] for row in scenes} == {"Motorcycle"}
    assert all(0.0 <= float(row["bad3_all"]) <= 100.0 for row in scenes)
    (model,) = _rows(out / "transfer-models.csv")
    assert int(model["steps"]) > 0 and float(model["wall_s"]) < 120
    assert (out / "models" / "tiny-seed0.pt.wall").is_file()
    assert (out / "transfer.png").read_bytes()[:4] == b"\x89PNG"
    again = _cli(["bench", "transfer", "--configs", str(config), "--count", "4", "--minutes",
                  "0.3", "--no-ceiling", "--out", str(out)], env=env)
    assert again.returncode == 0 and "tiny-seed0.pt: reused" in again.stderr, again.stderr
    # a step budget is another budget: the model is trained again, with exactly that many steps
    steps = _cli(["bench", "transfer", "--configs", str(config), "--count", "4", "--steps", "3",
                  "--no-ceiling", "--out", str(out)], env=env)
    assert steps.returncode == 0 and "reused" not in steps.stderr, steps.stderr
    (model,) = _rows(out / "transfer-models.csv")
    assert int(model["steps"]) == 3
    assert (out / "models" / "tiny-seed0.pt.budget").read_text() == "--steps 3\n"


def test_one_pass_step_equals_the_crop_by_crop_step(data):
    """The GPU's step (a batch in one pass, patches sampled at once) on the CPU: the same loss
    and gradients as the CPU's crop-by-crop step, up to float rounding."""
    from synth.jobs.train.steps import batch_loss as _batch_loss, one_pass_loss as _one_pass_loss

    batch = PatchBatches(open_sources([str(data)]), seed=4, radius=3, crops=6)[2]
    assert len({c.right.shape[1] for c in batch}) > 1  # strips of several widths: padding
    torch.manual_seed(1)
    net = PatchNet(Architecture(channels=8, layers=3))
    grads = []
    for step in (_batch_loss, _one_pass_loss):
        net.zero_grad(set_to_none=True)
        loss, n = step(net, batch, torch.device("cpu"))
        loss.backward()
        grads.append((float(loss.detach()), n, [p.grad.clone() for p in net.parameters()]))
    (la, na, ga), (lb, nb, gb) = grads
    assert na == nb == sum(c.ys.size for c in batch) and la > 0
    assert lb == pytest.approx(la, rel=1e-5)
    for a, b in zip(ga, gb, strict=True):
        torch.testing.assert_close(b, a, rtol=1e-4, atol=1e-6)
    assert _one_pass_loss(net, [], torch.device("cpu")) == (None, 0)


def test_the_header_records_the_device_and_the_batch(data, tmp_path, monkeypatch):
    from synth.jobs.train import CROPS, GPU_CROPS, default_crops

    out = tmp_path / "cpu.pt"
    _cli(["train", str(data), "--out", str(out), "--steps", "3", "--workers", "0",
          "--device", "cpu"], check=True)
    training = load_model(out).header["training"]
    assert training["device"] == "cpu" and training["crops"] == CROPS == 16
    assert training["batch"] == {"crops": 16, "crop": 32, "workers": 0, "step": "crop by crop"}
    one = tmp_path / "one.pt"
    code = ("from synth.jobs.train import TrainConfig, train; "
            f"train(TrainConfig(sources=({str(data)!r},), out={str(one)!r}, steps=3, crops=5), "
            "device='cpu', workers=0, show_progress=False, one_pass=True)")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    assert load_model(one).header["training"]["batch"] == {"crops": 5, "crop": 32, "workers": 0,
                                                           "step": "one pass"}
    assert default_crops("cpu") == 16
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert default_crops("auto") == GPU_CROPS


def _alive(pids: set[int]) -> list[int]:
    return [p for p in pids if Path(f"/proc/{p}").exists()
            and "zombie" not in Path(f"/proc/{p}/status").read_text().lower()]


def test_a_corrupt_sample_under_two_workers_ends_the_run_with_one_line(data, tmp_path):
    """The hang: a worker's exception, raised again by torch with the loader in its traceback,
    kept the workers alive and the trainer waiting for them after its Error: line. Bounded in
    time, so a regression fails instead of hanging the suite."""
    import shutil

    bad = tmp_path / "bad"
    shutil.copytree(data, bad)
    (source,) = open_sources([str(bad)])
    batches = PatchBatches([source], seed=0, radius=4, crops=1)
    item = batches.pairs[batches._pair_number(6)][1]  # met at step 6 (one crop per step)
    index = StereoDataset(bad, split="train").indices[item]
    png = bad / "MiddEval3" / "trainingF" / f"{index:06d}" / "im0.png"
    png.write_bytes(png.read_bytes()[:200])  # cut short: OpenCV cannot decode it
    out = tmp_path / "m.pt"
    proc = subprocess.Popen(CLI + ["train", str(bad), "--out", str(out), "--steps", "40",
                                   "--workers", "2", "--crops", "1", "--device", "cpu",
                                   "--checkpoint-minutes", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    workers: set[int] = set()
    deadline = time.monotonic() + 240
    while proc.poll() is None and time.monotonic() < deadline:
        workers.update(_children(proc.pid))
        time.sleep(0.2)
    if proc.poll() is None:
        proc.kill()
        proc.communicate()
        pytest.fail("train did not end after a worker failed (the DataLoader hang)")
    _, err = proc.communicate()
    errors = [line for line in err.splitlines() if line.startswith("Error:")]
    assert proc.returncode == 2 and len(errors) == 1 and "Traceback" not in err, err
    assert f"sample {index} " in errors[0] and f"{png}: a PNG cut short" in errors[0], errors[0]
    assert workers, "the run had no worker process to test"
    time.sleep(1.0)
    assert _alive(workers) == [], "worker processes outlived the trainer"
    assert not out.exists()  # no model
    blob = torch.load(Path(f"{out}.ckpt"), map_location="cpu", weights_only=True)
    assert blob["format"] == "stereoforge-train-checkpoint" and not blob["finished"]
    assert blob["state"]["step"] == 6  # the last step done before the corrupt sample
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")
                or p.suffix in (".tmp", ".lock")]


def _refused(tmp_path, words, **kw):
    from synth.jobs.train import TrainConfig, train

    options = {k: kw.pop(k) for k in ("device", "workers", "checkpoint_minutes") if k in kw}
    cfg = TrainConfig(**{"out": str(tmp_path / "m.pt"), "steps": 1, **kw})
    with pytest.raises(ValueError) as info:
        train(cfg, show_progress=False, **options)
    assert words in str(info.value) and "\n" not in str(info.value), str(info.value)
    assert list(tmp_path.iterdir()) == []  # refused before any work


def _no_gpu_device() -> str:
    count = torch.cuda.device_count() if torch.cuda.is_available() else 0
    return "cuda" if count == 0 else f"cuda:{count}"


@pytest.mark.parametrize("option, words", [
    ({"minutes": float("inf"), "steps": None}, "--minutes: expected a finite number in (0, "),
    ({"minutes": float("nan"), "steps": None}, "--minutes: expected a finite number"),
    ({"steps": 10**12}, "--steps: expected an integer in [1, 1000000000]"),
    ({"arch_options": {"channels": 1025}}, "channels: expected an integer 1..1024, got 1025"),
    ({"arch_options": {"layers": 33}}, "layers: expected an integer 1..32, got 33"),
    ({"arch_options": {"width": 3}}, "the mccnn-fast network has no option 'width'; its options: "
                                     "channels, layers"),
    ({"arch": "raft"}, "--arch: no network architecture 'raft'; architectures: mccnn-fast"),
    ({"crops": 10**6}, "--crops: expected an integer in [1, 4096]"),
    ({"seed": 2**64}, "--seed: expected an integer in [0, 9223372036854775807]"),
    ({"crop": 300}, "--crop 300 with the mccnn-fast network of 32 maps x 4 layers (9x9 patches) "
                    "needs images of at least 308x308 pixels"),
    ({"crop": 90, "arch_options": {"layers": 4}}, "the smallest of"),
    ({"device": "foo"}, "--device: expected auto, cpu, cuda or cuda:N, got 'foo'"),
    ({"device": _no_gpu_device()}, "--device: '"),
    ({"workers": -1}, "--workers: expected an integer in [0, 256]"),
    ({"checkpoint_minutes": float("nan")}, "--checkpoint-minutes: expected a finite number"),
])
def test_every_option_is_checked_before_any_work(data, tmp_path, option, words):
    _refused(tmp_path, words, sources=(str(data),), **option)


def test_a_run_that_learned_nothing_writes_no_model(data, tmp_path):
    out = tmp_path / "m.pt"
    r = _cli(["train", str(data), "--out", str(out), "--minutes", "0.001", "--workers", "0",
              "--device", "cpu"])
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and lines[-1].startswith("Error: --minutes 0.001: the budget ran "
                                                      "out before the first step"), r.stderr
    assert "no model written" in lines[-1] and "Traceback" not in r.stderr
    assert not out.exists()


def test_resume_refuses_another_seed(data, tmp_path):
    out = tmp_path / "m.pt"
    args = ["train", str(data), "--out", str(out), "--steps", "2", "--crops", "2", "--workers",
            "0", "--device", "cpu"]
    _cli(args, check=True)
    r = _cli([*args, "--resume", "--seed", "1"])
    assert r.returncode == 2, r.stderr
    assert "was made with seed = 0, this run asks for 1" in r.stderr


def test_the_training_split_holds_no_validation_sample(data):
    (source,) = open_sources([str(data)])
    everything = StereoDataset(data)
    assert source.n_val > 0 and source.n_train + source.n_val == len(everything)
    assert source.n_train == len(StereoDataset(data, split="train"))
    train = [source.load("train", i).left for i in range(source.n_train)]
    for j in range(source.n_val):
        val = source.load("val", j).left
        assert not any(np.array_equal(val, t) for t in train)


def test_a_checkpoint_replaces_the_old_one_atomically(data, tmp_path):
    """Written in place, a checkpoint cut by a kill is lost with the one before it; replaced by
    a rename, the old file (here also reachable by a hard link) is never touched."""
    from synth.jobs.train.checkpoint import State as _State, save_checkpoint as _save_checkpoint
    from synth.jobs.train.config import TrainConfig

    sources = open_sources([str(data)])
    cfg = TrainConfig(sources=(str(data),), out=str(tmp_path / "m.pt"), steps=3)
    torch.manual_seed(0)
    net = PatchNet(Architecture(channels=4, layers=2))

    class _Optimiser:  # torch.optim in this process (it renders) would import torch._dynamo
        def state_dict(self) -> dict:
            return {"state": {}, "param_groups": []}

    opt = _Optimiser()
    ckpt = tmp_path / "m.pt.ckpt"
    _save_checkpoint(ckpt, cfg, sources, net, opt, _State(step=1), finished=False)
    before = ckpt.read_bytes()
    os.link(ckpt, tmp_path / "earlier")
    _save_checkpoint(ckpt, cfg, sources, net, opt, _State(step=2), finished=False)
    assert (tmp_path / "earlier").read_bytes() == before
    assert torch.load(ckpt, weights_only=True)["state"]["step"] == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["earlier", "m.pt.ckpt"]


def test_memory_that_cannot_be_had_is_an_environment_error(data, tmp_path):
    import resource

    def limit():  # 8 GiB of address space: torch needs ~3.5 to start, the step asks for ~15 more
        resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))

    out = tmp_path / "m.pt"
    r = subprocess.run(CLI + ["train", str(data), "--out", str(out), "--steps", "2", "--workers",
                              "0", "--device", "cpu", "--channels", "1024", "--crops", "512",
                              "--crop", "80"], preexec_fn=limit, capture_output=True, text=True,
                       timeout=600)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 1 and "Traceback" not in r.stderr, r.stderr
    assert re.match(r"Error: out of memory: could not allocate [0-9.]+ GiB for the mccnn-fast "
                    r"network of 1024 maps x 4 layers \(9x9 patches\) on a batch of 512 crops of "
                    r"80x80 pixels", lines[-1]), \
        lines[-1]
    assert not out.exists()


@pytest.mark.parametrize("option, words", [
    ({"configs": []}, "--configs: expected dataset configs separated by commas"),
    ({"configs": ["", "", ""]}, "got ',,'"),
    ({"configs": ["flying", "flying"]}, "--configs: flying comes twice"),
    ({"device": "foo"}, "--device: expected auto, cpu, cuda or cuda:N, got 'foo'"),
    ({"device": _no_gpu_device()}, "--device: '"),
    ({"minutes": float("inf")}, "--minutes: expected a finite number"),
    ({"seeds": []}, "--seeds: give at least one seed"),
    ({"steps": 0}, "--steps: expected an integer in [1, 1000000000], got 0"),
    ({"real": ["eth3d:/nonexistent/eth3d"], "ceiling": False}, "--real 'eth3d:/nonexistent/eth3d'"
                                                               ": /nonexistent/eth3d is not a "
                                                               "folder"),
])
def test_bench_transfer_refuses_bad_arguments_before_rendering(tmp_path, option, words):
    from synth.jobs.bench.transfer import bench_transfer

    with pytest.raises(ValueError, match=re.escape(words)):
        bench_transfer(**{"configs": ["flying"], "count": 2, "minutes": 0.1, "out": tmp_path,
                          **option})
    assert list(tmp_path.iterdir()) == []


#: A second architecture, in a file of its own: one registration makes it trainable, savable,
#: loadable and a MATCHER (docs/extending.md).
TINY_NET = '''\
from dataclasses import dataclass
from typing import ClassVar

from torch import nn
from torch.nn import functional as F

from matcher.learned import Arch, register_architecture
from matcher.learned.registry import Option


class TinyNet(nn.Module):
    def __init__(self, arch):
        super().__init__()
        self.arch = arch
        self.conv = nn.Conv2d(1, arch.width, 2 * arch.radius + 1)

    def forward(self, x):
        return F.normalize(self.conv(x), dim=1)


@register_architecture
@dataclass(frozen=True)
class Tiny(Arch):
    NAME: ClassVar[str] = "tiny-test"
    OPTIONS: ClassVar[tuple] = (Option("width", 6, 1, 64, "features"),
                                Option("radius", 2, 1, 5, "halo: a (2r+1)^2 kernel"))
    width: int = 6
    radius: int = 2

    halo = property(lambda self: self.radius)
    features = property(lambda self: self.width)
    weights = property(lambda self: self.width * ((2 * self.radius + 1) ** 2 + 1))

    def network(self):
        return TinyNet(self)
'''


def test_a_second_architecture_is_one_file_and_one_registration(data, tmp_path, monkeypatch):
    (tmp_path / "tiny_arch.py").write_text(TINY_NET)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(tmp_path), *filter(None, [os.environ.get("PYTHONPATH")])])}
    boot = [sys.executable, "-c", "import tiny_arch; from synth.cli import main; main()"]
    out = tmp_path / "tiny.pt"
    r = subprocess.run(boot + ["train", str(data), "--out", str(out), "--steps", "3", "--crops",
                               "2", "--workers", "0", "--device", "cpu", "--arch", "tiny-test",
                               "--arch-option", "width=5"], capture_output=True, text=True,
                       env=env)
    assert r.returncode == 0, r.stderr
    assert "tiny-test network of width 5, radius 2 (5x5 patches)" in r.stderr
    monkeypatch.syspath_prepend(str(tmp_path))
    import tiny_arch  # noqa: F401 - registers it in this process too

    model = load_model(out)
    assert model.header["architecture"] == {"name": "tiny-test", "width": 5, "radius": 2}
    assert model.arch.halo == 2 and model.arch.features == 5
    sample = StereoDataset(data)[0]
    est = match_learned(sample["left"], sample["right"], model, max_disparity=32)
    assert est.disparity.shape == sample["disp"].shape and est.window == 5
    assert resolve_matcher(f"learned:{out}")(sample["left"], sample["right"],
                                             max_disparity=32).shape == sample["disp"].shape
    # an option it lacks, one out of range: one line each, before any work
    for option, words in (("layers=3", "the tiny-test network has no option 'layers'; its "
                                       "options: width, radius"),
                          ("radius=9", "radius: expected an integer 1..5, got 9")):
        r = subprocess.run(boot + ["train", str(data), "--out", str(tmp_path / "x.pt"), "--steps",
                                   "1", "--arch", "tiny-test", "--arch-option", option],
                           capture_output=True, text=True, env=env)
        assert r.returncode == 2 and r.stderr.strip().splitlines()[-1].startswith("Error:"), r.stderr
        assert words in r.stderr and not (tmp_path / "x.pt").exists()
    # a process that never registered it reads the file as another program's model
    r = _cli(["match", str(tmp_path / "nope.png"), "x.png", "--matcher", f"learned:{out}",
              "--out", str(tmp_path / "d.pfm")])
    assert r.returncode != 0 and "architecture 'tiny-test', this version of stereoforge reads " \
        "'mccnn-fast' models" in r.stderr, r.stderr
