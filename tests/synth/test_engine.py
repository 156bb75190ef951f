"""Engines: argument checks, the in-process loop, and Ray (optional extra, slow)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from synth.dataset.engine.tasks import ray_available, run_tasks


class _Square:
    width, height, backend = 16, 16, "auto"

    def __call__(self, index, renderer):
        return {"square": index * index, "backend": renderer.backend}


class _Threads:
    width, height, backend = 16, 16, "auto"

    def __call__(self, index, renderer):
        import gc
        import os

        import cv2
        import numba

        return {"square": index * index, "backend": renderer.backend, "pid": os.getpid(),
                "numba": numba.get_num_threads(), "cv2": cv2.getNumThreads(),
                "frozen": gc.get_freeze_count()}


class _Fails:
    width, height, backend = 16, 16, "auto"

    def __call__(self, index, renderer):
        if index == 2:
            raise RuntimeError("sample 2 is broken")
        return {}


def test_arguments_are_checked():
    for kwargs, match in [({"workers": 0}, "workers must be"), ({"engine": "dask"}, "engine"),
                          ({"address": "ray://x:1"}, "applies to engine='ray' only")]:
        with pytest.raises(ValueError, match=match):
            run_tasks(_Square(), [1], **kwargs)
    assert list(run_tasks(_Square(), [], workers=4)) == []



def test_run_dataset_checks_the_engine_arguments_before_making_the_folder(tmp_path):
    from synth.dataset.run import run_dataset

    for kwargs, match in [({"workers": 0}, "workers must be"), ({"engine": "dask"}, "engine"),
                          ({"address": "127.0.0.1:1"}, "applies to engine='ray' only")]:
        with pytest.raises(ValueError, match=match):
            run_dataset("planes", tmp_path / "out", count=1, progress=False, **kwargs)
        assert not (tmp_path / "out").exists()


@pytest.mark.gl
def test_local_engine_runs_every_index_once(renderer):
    out = dict(run_tasks(_Square(), [3, 1, 2], workers=1))
    assert {i: r["square"] for i, r in out.items()} == {3: 9, 1: 1, 2: 4}
    assert {r["backend"] for r in out.values()} == {renderer.backend}


@pytest.mark.gl
def test_local_engine_stops_at_the_first_failure(renderer):
    seen = []
    with pytest.raises(RuntimeError, match="sample 2 is broken"):
        for index, _ in run_tasks(_Fails(), [0, 1, 2, 3], workers=1):
            seen.append(index)
    assert seen == [0, 1]


@pytest.mark.gl
def test_two_workers_run_every_index_once_with_their_share_of_threads(renderer):
    out = dict(run_tasks(_Threads(), [4, 0, 3, 1, 2], workers=2))
    assert {i: r["square"] for i, r in out.items()} == {0: 0, 1: 1, 2: 4, 3: 9, 4: 16}
    assert {r["backend"] for r in out.values()} == {renderer.backend}
    share = max(1, (os.cpu_count() or 1) // 2)  # OpenCV and numba: cores // workers each
    assert {(r["numba"], r["cv2"]) for r in out.values()} == {(share, share)}
    assert len({r["pid"] for r in out.values()}) <= 2
    # each worker freezes its heap after its first sample (freeze_heap): that one saw nothing
    # frozen, every later one the objects alive then
    for pid in {r["pid"] for r in out.values()}:
        frozen = sorted(r["frozen"] for r in out.values() if r["pid"] == pid)
        assert frozen[0] == 0 and all(n > 10_000 for n in frozen[1:])
    assert any(r["frozen"] for r in out.values())  # 5 samples, 2 workers: one ran several


@pytest.mark.gl
def test_two_workers_stop_at_the_first_failure(renderer):
    with pytest.raises(RuntimeError, match="sample 2 is broken"):
        list(run_tasks(_Fails(), [0, 1, 2, 3], workers=2))


_PRELOAD = """
import os, sys, threading
import cv2, numpy, scipy.linalg  # their BLAS thread pools start at import (fork-aware)
libraries = len(os.listdir("/proc/self/task"))
from synth.dataset.config.parse import load_config
from synth.dataset.sample import SampleTask
from synth.dataset.engine.tasks import _preload
modules = _preload(SampleTask(load_config("planes"), "/nonexistent", "middlebury", "auto"))
for name in modules:
    __import__(name)
print(sorted(modules))
print([m for m in sys.modules if m.split(".")[0] in ("OpenGL", "pyrender")])
print(threading.active_count(), len(os.listdir("/proc/self/task")) - libraries)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/self/task: Linux")
def test_the_fork_server_preload_opens_no_gl_and_starts_no_thread():
    out = subprocess.run([sys.executable, "-c", _PRELOAD], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0] == str(sorted(["synth.dataset.engine.guard", "synth.dataset.engine.tasks",
                                 "synth.dataset.sample", "synth.pair",
                                 "synth.dataset.engine.warm"]))
    assert out[1] == "[]"  # nothing GL: a forked GL state would be unusable
    # one Python thread, and no OS thread beyond numpy's, SciPy's and OpenCV's BLAS pools
    # (which re-initialise after a fork): numba's OpenMP pool is never started there
    assert out[2] == "1 0"


_FAULTS = """
import resource, sys
import numpy as np
if sys.argv[1] == "tuned":
    from synth.dataset.engine.tasks import _tune_malloc
    _tune_malloc()
sizes = [3 << 20, 5 << 20, 2 << 20, 7 << 20]  # numpy temporaries of a few MB, as in a sample
for _ in range(3):
    arrays = [np.ones(n, np.uint8) for n in sizes]
    del arrays
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(20):
    arrays = [np.ones(n, np.uint8) for n in sizes]
    del arrays
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc malloc tuning: Linux")
def test_worker_malloc_tuning_reuses_freed_memory():
    faults = {}
    for mode in ("default", "tuned"):
        out = subprocess.run([sys.executable, "-c", _FAULTS, mode], capture_output=True,
                             text=True, check=True)
        faults[mode] = int(out.stdout)
    # default glibc: every allocation maps fresh pages (~1500 faults per round of 17 MB)
    assert faults["default"] > 20 * 1000
    assert faults["tuned"] < faults["default"] / 20


def _require_ray(require_or_skip) -> None:
    if not ray_available():
        require_or_skip("ray is not installed (optional extra: pip install ray)",
                        env="STEREOFORGE_REQUIRE_RAY")


def test_a_local_ray_that_cannot_start_leaves_no_new_folder(tmp_path, require_or_skip,
                                                            monkeypatch):
    _require_ray(require_or_skip)
    import ray

    from synth.dataset.run import run_dataset

    def init(*args, **kwargs):
        raise RuntimeError("Ray could not start its head (simulated)")

    monkeypatch.setattr(ray, "init", init)
    with pytest.raises(RuntimeError, match="simulated"):
        run_dataset("planes", tmp_path / "new", count=1, engine="ray", progress=False)
    assert not (tmp_path / "new").exists()


@pytest.mark.gl
@pytest.mark.slow
def test_ray_engine_writes_the_same_bytes_as_local(tmp_path, renderer, require_or_skip):
    _require_ray(require_or_skip)
    import ray

    from synth.dataset.config.parse import loads_config
    from synth.dataset.run import SampleError, run_dataset

    cfg = loads_config("seed = 2\ncount = 4\n[rig]\nwidth = 32\nheight = 24\n[scene]\n"
                       'base = {choice = ["fronto_plane", "flying"]}\noccluders = 1\n'
                       "[photometric]\nnoise_sigma = 2.0\n")
    run_dataset(cfg, out=tmp_path / "local", workers=1, progress=False)
    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False,
             _node_ip_address="127.0.0.1")  # a new local Ray, on the loopback only
    try:
        run_dataset(cfg, out=tmp_path / "ray", workers=2, engine="ray", progress=False)
        # a failing sample comes back as the SampleError naming it (far = 5 m < flying's wall)
        bad = loads_config("seed = 2\ncount = 4\n[rig]\nwidth = 32\nheight = 24\n"
                           "far = 5.0\n[scene]\nbase = 'flying'\n")
        with pytest.raises(SampleError,
                           match=r"sample \d \(seed \d+\) failed: DepthRangeError: object"):
            run_dataset(bad, out=tmp_path / "bad", workers=2, engine="ray", progress=False)
        assert not list((tmp_path / "bad").glob("MiddEval3/trainingF/*"))
        assert not [p for p in (tmp_path / "bad").iterdir() if ".tmp-" in p.name]
    finally:
        ray.shutdown()
    local, remote = tmp_path / "local", tmp_path / "ray"
    files = sorted(str(p.relative_to(local)) for p in local.rglob("*") if p.is_file())
    assert files == sorted(str(p.relative_to(remote)) for p in remote.rglob("*") if p.is_file())
    for f in files:
        assert Path(local, f).read_bytes() == Path(remote, f).read_bytes(), f


_EARLY_SERVER = """
import json, sys, time
sys.path.insert(0, sys.argv[1])
import psutil
from synth.dataset.engine.tasks import run_tasks, start_worker_server

start_worker_server(["early_task"])  # before this process imports the task's module
servers, deadline = [], time.monotonic() + 10  # polled: it may still be exec'ing under load
while not servers and time.monotonic() < deadline:
    servers = [p.pid for p in psutil.Process().children()
               if "forkserver" in " ".join(p.cmdline())]
    time.sleep(0 if servers else 0.05)
import early_task

out = dict(run_tasks(early_task.Parent(), range(4), workers=2))
print(json.dumps({"servers": servers, "parents": sorted({r["ppid"] for r in out.values()}),
                  "squares": [out[i]["square"] for i in range(4)]}))
"""


@pytest.mark.gl
@pytest.mark.slow
def test_an_early_started_server_forks_the_workers(tmp_path):
    (tmp_path / "early_task.py").write_text(
        "import os\n\n\nclass Parent:\n    width, height, backend = 16, 16, 'auto'\n\n"
        "    def __call__(self, index, renderer):\n"
        "        return {'ppid': os.getppid(), 'square': index * index}\n")
    out = subprocess.run([sys.executable, "-c", _EARLY_SERVER, str(tmp_path)],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    res = json.loads(out.stdout)
    assert len(res["servers"]) == 1  # started by start_worker_server, before any run
    assert res["parents"] == res["servers"]  # both workers were forked by it
    assert res["squares"] == [0, 1, 4, 9]


def test_an_unreachable_ray_address_fails_fast_with_the_address(tmp_path, require_or_skip):
    """`--engine ray --address 127.0.0.1:1` used to wait for ever."""
    import time

    from click.testing import CliRunner

    from synth.cli import main

    _require_ray(require_or_skip)
    t0 = time.monotonic()
    result = CliRunner().invoke(main, ["dataset", "planes", "--count", "2", "--engine", "ray",
                                       "--address", "127.0.0.1:1", "--out", str(tmp_path / "o")])
    assert time.monotonic() - t0 < 60
    assert result.exit_code == 1, result.output
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1 and "no Ray cluster answers at 127.0.0.1:1" in errors[0]
    assert "Traceback" not in result.output
    assert not (tmp_path / "o").exists()  # refused before the dataset folder is made


def test_ray_address_forms():
    from synth.dataset.engine.tasks import check_ray_address

    check_ray_address("auto")  # Ray resolves these itself: nothing to check, nothing raised
    check_ray_address("ray://head:10001")
    with pytest.raises(ValueError, match="expected HOST:PORT of a Ray head"):
        check_ray_address("127.0.0.1")
