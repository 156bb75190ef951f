"""The dataset benchmark's bookkeeping (rates are measured, never asserted: no timed tests)."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from synth.jobs.bench.dataset import (
    _cpu_seconds,
    _steady_cpu_per_pair,
    bench_dataset,
    profile_dataset,
)

TINY = """\
name = "tiny"
[rig]
width = 32
height = 24
[scene]
base = "fronto_plane"
texture = "noise"
[photometric]
noise_sigma = 1.0
"""


def test_steady_cpu_counts_each_worker_from_its_first_completion():
    stamps = [{"pid": 1, "cpu": 10.0}, {"pid": 2, "cpu": 5.0}, {"pid": 1, "cpu": 10.5},
              {"pid": 2, "cpu": 5.2}, {"pid": 1, "cpu": 11.0}]
    # worker 1: 1.0 s for 2 pairs, worker 2: 0.2 s for 1 pair
    assert _steady_cpu_per_pair(stamps) == pytest.approx(1.2 / 3)
    assert math.isnan(_steady_cpu_per_pair([{"pid": 1, "cpu": 3.0}]))


_BUSY = """
import sys, time
from multiprocessing import Process
def burn():
    while time.process_time() < 0.3:
        pass
if __name__ == "__main__":
    p = Process(target=burn)  # a grandchild, as the workers forked by the engine's fork server
    p.start(); p.join()
    burn()
    print(time.process_time(), flush=True)
    sys.stdin.read()
"""


def test_cpu_counts_live_children_and_what_they_reaped():
    before = _cpu_seconds()
    child = subprocess.Popen([sys.executable, "-c", _BUSY], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True)
    try:
        own = float(child.stdout.readline())  # the child's CPU; its reaped grandchild: 0.3 s
        assert _cpu_seconds() - before >= own + 0.3 - 0.05  # clock ticks of 10 ms
    finally:
        child.communicate("")


@pytest.mark.gl
def test_bench_and_profile_rows(tmp_path, renderer):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    (row,) = bench_dataset(configs=(str(path),), count=3, workers=(1,))
    assert (row["config"], row["size"], row["workers"], row["pairs"]) == ("tiny", "32x24", 1, 3)
    assert row["steady_cpu_ms_per_pair"] > 0 and row["efficiency"] == 1
    assert row["cold"] is None  # one worker: no worker server
    assert row["minutes_for_35454"] == pytest.approx(35454 / row["steady_pairs_per_s"] / 60)
    (big,) = bench_dataset(configs=(str(path),), count=2, workers=(1,), size=(48, 30))
    assert big["size"] == "48x30"
    prof = profile_dataset(str(path), count=2)
    stages = ("draw", "search", "render", "photometric", "stats", "write")
    for suffix in ("", "_cpu"):
        assert prof[f"total{suffix}_ms"] == pytest.approx(
            sum(prof[f"{s}{suffix}_ms"] for s in stages))
    assert prof["render_cpu_ms"] > 0 and prof["texture_ms"] > 0 and prof["commit_ms"] > 0
    # the GL passes are parts of render, each measured (meshes includes the texture synthesis)
    parts = [prof[f"{name}_ms"] for name in ("meshes", "upload", "colour", "depth")]
    assert all(p > 0 for p in parts) and sum(parts) <= prof["render_ms"]
    for suffix in ("", "_cpu"):  # the work around the GL passes
        assert prof[f"outside_gl{suffix}_ms"] == pytest.approx(
            prof[f"total{suffix}_ms"] - sum(prof[f"{name}{suffix}_ms"]
                                            for name in ("upload", "colour", "depth")))
    assert 0 < prof["outside_gl_cpu_ms"] < prof["total_cpu_ms"]
    assert prof["image_deflate"] in ("isal", "zlib")  # the configuration's own (unset)
    small = profile_dataset(str(path), count=1, size=(48, 30), image_deflate="stored")
    assert (small["size"], small["image_deflate"]) == ("48x30", "stored")
    (stored,) = bench_dataset(configs=(str(path),), count=2, workers=(1,),
                              image_deflates=("stored",))
    assert stored["image_deflate"] == "stored" and stored["pairs"] == 2
    with pytest.raises(ValueError, match="image_deflate: expected one of"):
        bench_dataset(configs=(str(path),), count=2, workers=(1,), image_deflates=("zstd",))


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.ray
def test_bench_on_ray_commits_every_returned_sample_in_the_driver(tmp_path, renderer,
                                                                  require_or_skip,
                                                                  monkeypatch):
    from synth.dataset import run
    from synth.dataset.engine.tasks import ray_available

    if not ray_available():
        require_or_skip("ray is not installed (optional extra: pip install ray)",
                        env="STEREOFORGE_REQUIRE_RAY")
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    committed = []
    original = run.commit_files

    def commit(out, index, files, fmt):
        committed.append((index, sorted(files)))
        original(out, index, files, fmt)

    monkeypatch.setattr(run, "commit_files", commit)
    (row,) = bench_dataset(configs=(str(path),), count=3, workers=(2,), engine="ray")
    assert (row["engine"], row["workers"], row["pairs"], row["cold"]) == ("ray", 2, 3, None)
    assert sorted(i for i, _ in committed) == [0, 1, 2]  # the actors wrote nothing themselves
    assert all("records/%06d.json" % i in names for i, names in committed)
    assert row["driver_cpu_ms_per_pair"] > 0 and row["steady_cpu_ms_per_pair"] > 0
    with pytest.raises(ValueError, match="engine must be one of local, ray"):
        bench_dataset(configs=(str(path),), count=1, engine="dask")


@pytest.mark.gl
@pytest.mark.slow
def test_bench_marks_only_the_first_multi_worker_run_cold(tmp_path, renderer):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    rows = bench_dataset(configs=(str(path), str(path)), count=3, workers=(1, 2))
    assert [(r["workers"], r["cold"]) for r in rows] == [(1, None), (2, True), (1, None),
                                                        (2, False)]
    assert all(r["pairs_per_s"] > 0 and r["steady_pairs_per_s"] > 0 for r in rows)


@pytest.mark.parametrize(("args", "message"), [
    (["--workers", "1,two"], "--workers must be positive ints separated by commas, got '1,two'"),
    (["--workers", "0"], "--workers must be positive ints"),
    (["--configs", " , "], "--configs is empty"),
    (["--configs", "no-such-config"], "no-such-config"),
    (["--size", "960by540"], "bad size '960by540': expected WIDTHxHEIGHT"),
    (["--size", "64x48,32x24"], "--size takes one WxH, got '64x48,32x24'"),
])
def test_bench_dataset_cli_rejects_bad_options(tmp_path, args, message):
    from click.testing import CliRunner

    from synth.cli import main

    result = CliRunner().invoke(main, ["bench", "dataset", "--out", str(tmp_path), *args])
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert not any(tmp_path.iterdir())


def test_resized_keeps_the_field_of_view():
    from synth.dataset import load_config
    from synth.jobs.bench.dataset import resized

    cfg = load_config("flying")
    big = resized(cfg, 960, 540)
    assert (big.rig.width, big.rig.height) == (960, 540)
    assert big.rig.fx / big.rig.width == cfg.rig.fx / cfg.rig.width
    assert big.scene == cfg.scene and big.seed == cfg.seed
