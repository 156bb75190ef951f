"""The Ray engine on a real two-node cluster (``ray.cluster_utils.Cluster``), all on 127.0.0.1.

One cluster for the module (a start costs seconds): a head and one worker node, one CPU each,
so two actors land on two nodes. The driver joins on the loopback; the workers return the bytes
and only the driver writes (``memory://`` is visible to the driver process alone).
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

from synth.dataset.engine.tasks import ray_available

pytestmark = [pytest.mark.ray, pytest.mark.gl, pytest.mark.slow]

_CONFIG = ("seed = 2\ncount = {count}\n[rig]\nwidth = 32\nheight = 24\n[scene]\n"
           'base = {{choice = ["fronto_plane", "flying"]}}\noccluders = 1\n'
           "[photometric]\nnoise_sigma = 2.0\n")
_COUNT = 6


def _files(root: Path) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file() and p.name != ".lock"}


@pytest.fixture(scope="module")
def cluster(require_or_skip):
    if not ray_available():
        require_or_skip("ray is not installed (optional extra: pip install ray)",
                        env="STEREOFORGE_REQUIRE_RAY")
    from ray.cluster_utils import Cluster

    args = {"node_ip_address": "127.0.0.1", "num_cpus": 1, "include_dashboard": False}
    c = Cluster(initialize_head=True, head_node_args=args)
    try:
        c.add_node(**args)
        c.wait_for_nodes()
        yield c
    finally:
        c.shutdown()


def _node_workers(node) -> list:
    """The processes under ``node``'s raylet (its workers, the actor among them)."""
    import psutil
    from ray._private import ray_constants

    raylet = node.all_processes[ray_constants.PROCESS_TYPE_RAYLET][0].process.pid
    return psutil.Process(raylet).children(recursive=True)


def _actor_ready_on(node) -> bool:
    """Whether a started worker actor runs on ``node``: a process under its raylet titled
    ``ray::_RayWorker`` (idle) or ``ray::_RayWorker.run`` (Ray names its actor processes so;
    ``ray::_RayWorker.__init__`` while the renderer opens)."""
    import psutil

    for child in _node_workers(node):
        try:
            title = " ".join(child.cmdline())
        except psutil.Error:
            continue
        if title.startswith("ray::_RayWorker") and "__init__" not in title:
            return True
    return False


@pytest.fixture(scope="module")
def config_file(tmp_path_factory) -> Path:
    """The configuration, as a file (dataset.json names its source)."""
    path = tmp_path_factory.mktemp("config") / "c.toml"
    path.write_text(_CONFIG.format(count=_COUNT))
    return path


@pytest.fixture(scope="module")
def local_runs(tmp_path_factory, renderer, config_file):
    """Local runs with 1 and 2 workers: the reference bytes."""
    from synth.dataset.config.parse import load_config
    from synth.dataset.run import run_dataset

    root = tmp_path_factory.mktemp("local")
    cfg = load_config(config_file)
    runs = {}
    for workers in (1, 2):
        run_dataset(cfg, root / f"w{workers}", workers=workers, progress=False)
        runs[workers] = _files(root / f"w{workers}")
    assert runs[1] == runs[2]
    return runs[1]


def test_the_cli_joins_a_loopback_cluster_and_writes_the_local_bytes(tmp_path, cluster,
                                                                     config_file, local_runs):
    """`stereoforge dataset --engine ray --address 127.0.0.1:PORT`, in a fresh process without
    RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER in its environment: the engine sets it before importing
    Ray (without it the driver rewrote 127.0.0.1 to the interface address and waited for ever)."""
    env = {k: v for k, v in os.environ.items() if k != "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"}
    out = subprocess.run(
        [str(Path(sys.executable).with_name("stereoforge")), "dataset", str(config_file),
         "--engine", "ray", "--workers", "2", "--address", cluster.address, "--out", str(tmp_path / "o")],
        capture_output=True, text=True, timeout=240, env=env)
    assert out.returncode == 0, out.stderr[-3000:]
    assert f"{_COUNT} rendered" in out.stdout
    assert _files(tmp_path / "o") == local_runs


def test_workers_do_not_write_memory_urls_get_the_local_bytes(cluster, config_file,
                                                             local_runs):
    import fsspec

    from synth.dataset.config.parse import load_config
    from synth.dataset.storage.integrity import verify_dataset
    from synth.dataset.run import run_dataset

    cfg = load_config(config_file)
    url = "memory://ray-cluster-test"
    # one actor here, two in the CLI test: Ray with 1 and 2 workers, both against local 1 and 2
    run = run_dataset(cfg, url, workers=1, engine="ray", address=cluster.address,
                      progress=False)
    assert run.rendered == _COUNT
    fs = fsspec.filesystem("memory")
    got = {f.removeprefix("/ray-cluster-test/"): hashlib.sha256(fs.cat_file(f)).hexdigest()
           for f in fs.find("/ray-cluster-test")}
    assert got == local_runs  # no .lock on an object store; every other file, same bytes
    assert verify_dataset(url) == []
    fs.rm("/ray-cluster-test", recursive=True)


def test_a_node_that_dies_mid_run_loses_no_sample_and_leaves_no_partial_file(
        tmp_path, cluster, local_runs, caplog):
    """The worker node is removed (its raylet and actor killed) once the run has committed a
    sample: its sample in flight is run again on the head's actor."""
    import ray

    from synth.dataset.config.parse import loads_config
    from synth.dataset.storage.integrity import verify_dataset
    from synth.dataset.run import run_dataset

    count = 30
    cfg = loads_config(_CONFIG.format(count=count))
    out = tmp_path / "o"
    ray.init(address=cluster.address, include_dashboard=False, log_to_driver=False)
    errors: list[BaseException] = []

    def drive() -> None:
        try:
            run_dataset(cfg, out, workers=2, engine="ray", progress=False)
        except BaseException as exc:  # noqa: BLE001 - reported by the test below
            errors.append(exc)

    thread = threading.Thread(target=drive)
    worker_node = cluster.list_all_nodes()[1]
    try:
        thread.start()
        deadline = time.monotonic() + 180
        done = []
        # mid-run: samples committed, and the worker node's actor started (else the head's actor
        # can finish everything before that one is ready, and its loss is never seen)
        while ((len(done) < 2 or not _actor_ready_on(worker_node))
               and time.monotonic() < deadline and thread.is_alive()):
            done = list(out.glob("records/" + "[0-9]" * 6 + ".json"))
            time.sleep(0.01)
        # the node dies whole: its raylet and, at the same moment, its processes (Ray's own
        # removal kills the raylet only, and an actor outlives it for a while, serving the
        # driver directly: a short run would end before anything is lost)
        workers = _node_workers(worker_node)
        cluster.remove_node(worker_node, allow_graceful=False)
        for proc in workers:
            with contextlib.suppress(psutil.Error):
                proc.kill()
        removed_at = len(done)
        thread.join(timeout=240)
    finally:
        ray.shutdown()
    assert not thread.is_alive() and not errors, errors
    assert 2 <= removed_at < count, "the node was not removed mid-run"
    lost = [r.getMessage() for r in caplog.records if "Ray worker was lost" in r.getMessage()]
    assert any("runs again" in m for m in lost), lost  # its sample in flight was retried
    assert verify_dataset(out) == []  # every sample, every file whole, no stray .tmp folder
    reference = _files(out)
    assert len(list((out / "records").glob("*.json"))) == count

    def first(files: dict) -> dict:  # the files of samples 0 .. _COUNT - 1
        return {k: v for k, v in files.items()
                if (m := re.search(r"(?:^|/)(\d{6})(?:/|\.json$)", k)) and int(m[1]) < _COUNT}

    # the first samples' bytes equal the local run's (same seed, same bytes, whatever the node)
    assert first(reference) == first(local_runs) and first(reference)


def test_bench_dataset_measures_a_cluster_at_its_address(cluster, config_file):
    """`bench dataset --engine ray --address`: the actors run on the cluster's two nodes, this
    process commits what they return (its CPU per pair is the driver's)."""
    import ray

    from synth.jobs.bench.dataset import bench_dataset

    rows = bench_dataset(configs=(str(config_file),), count=4, workers=(1, 2), engine="ray",
                         address=cluster.address)
    assert [(r["engine"], r["workers"], r["pairs"]) for r in rows] == [("ray", 1, 4), ("ray", 2, 4)]
    assert all(r["steady_pairs_per_s"] > 0 and r["driver_cpu_ms_per_pair"] > 0 for r in rows)
    assert all(r["pairs_per_cpu_s"] != r["pairs_per_cpu_s"] for r in rows)  # NaN: remote CPUs
    assert rows[0]["efficiency"] == 1 and rows[1]["efficiency"] > 0
    assert not ray.is_initialized()  # the bench left the cluster it joined
