"""The Ray engine's failure paths, for real on 127.0.0.1: a cluster with no CPU for the workers,
and an address that answers but is no Ray.

The driver runs the CLI in a fresh process (Ray imported there by the engine, on the loopback;
this process imports Ray for the cluster without RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER). The stall
timeout is lowered in that process through ``synth.dataset.engine.ray_driver.RAY_STALL_TIMEOUT_S``.
"""

from __future__ import annotations

import os
import socketserver
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from synth.dataset.engine.tasks import ray_available

pytestmark = [pytest.mark.ray, pytest.mark.slow]

_CONFIG = ("seed = 4\ncount = 3\n[rig]\nwidth = 32\nheight = 24\n[scene]\n"
           'base = "fronto_plane"\n[photometric]\nnoise_sigma = 2.0\n')
_STALL_S = 3.0
# the CLI with the stall timeout lowered: argv = [stall seconds, stereoforge's arguments...]
_CLI = """
import sys
from synth.dataset.engine import ray_driver
ray_driver.RAY_STALL_TIMEOUT_S = float(sys.argv[1])
from synth.cli import main
main(sys.argv[2:], prog_name="stereoforge")
"""


def _require_ray(require_or_skip) -> None:
    if not ray_available():
        require_or_skip("ray is not installed (optional extra: pip install ray)",
                        env="STEREOFORGE_REQUIRE_RAY")


def _files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file() and p.name != ".lock"}


def _cli(args: list[str], *, stall: float = 300.0) -> tuple[subprocess.CompletedProcess, float]:
    """``stereoforge ARGS`` in a fresh process without the loopback variable; its wall time."""
    env = {k: v for k, v in os.environ.items() if k != "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"}
    t0 = time.monotonic()
    out = subprocess.run([sys.executable, "-c", _CLI, str(stall), *args], capture_output=True,
                         text=True, timeout=240, env=env)
    return out, time.monotonic() - t0


def _one_error(out: subprocess.CompletedProcess) -> str:
    text = out.stdout + out.stderr
    errors = [line for line in text.splitlines() if line.startswith("Error:")]
    assert out.returncode == 1, text[-3000:]
    assert len(errors) == 1, text[-3000:]
    assert "Traceback" not in text, text[-3000:]
    return errors[0]


@pytest.fixture(scope="module")
def no_cpu_cluster(require_or_skip) -> Iterator[object]:
    """A head on 127.0.0.1 with no CPU: an actor (num_cpus=1) can never be scheduled."""
    _require_ray(require_or_skip)
    from ray.cluster_utils import Cluster

    c = Cluster(initialize_head=True, head_node_args={
        "node_ip_address": "127.0.0.1", "num_cpus": 0, "include_dashboard": False})
    try:
        c.wait_for_nodes()
        yield c
    finally:
        c.shutdown()


@pytest.fixture
def not_ray() -> Iterator[str]:
    """``127.0.0.1:PORT`` of a TCP server that accepts and closes: no Ray handshake."""

    class Close(socketserver.BaseRequestHandler):
        def handle(self) -> None:
            pass

    server = socketserver.ThreadingTCPServer(("127.0.0.1", 0), Close)
    server.daemon_threads = True
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)


@pytest.fixture(scope="module")
def config_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("config") / "c.toml"
    path.write_text(_CONFIG)
    return path


@pytest.mark.gl
def test_no_worker_can_start_one_error_and_a_resumable_folder(tmp_path, no_cpu_cluster,
                                                             config_file, renderer):
    """A cluster without a free CPU used to be waited on for 300 s, then left a traceback-free
    error; here the stall timeout is 3 s. The folder is left as a local run can finish it."""
    from synth.dataset.run import run_dataset

    out = tmp_path / "o"
    result, seconds = _cli(["dataset", str(config_file), "--engine", "ray", "--workers", "2",
                            "--address", no_cpu_cluster.address, "--out", str(out)],
                           stall=_STALL_S)
    error = _one_error(result)
    assert ("engine='ray': no Ray worker could start within 3 s (too few free CPUs on the "
            "cluster?)") in error
    assert seconds < 60, seconds  # a sanity bound (Ray's start-up included), not a benchmark
    assert not list(out.glob("MiddEval3/trainingF/*")) and not list(out.glob("records/*"))
    assert not [p for p in out.iterdir() if ".tmp-" in p.name]
    run = run_dataset(config_file, out, progress=False)  # the same folder, finished locally
    assert (run.rendered, run.skipped) == (3, 0)
    run_dataset(config_file, tmp_path / "local", progress=False)
    assert _files(out) == _files(tmp_path / "local")


def test_an_address_that_is_no_ray_leaves_no_folder(tmp_path, not_ray, config_file,
                                                    require_or_skip):
    """The TCP check passes, Ray's handshake fails: the run used to leave a new folder with
    only dataset.json (and .lock) behind, and Ray tried its GCS 20 times (~14 minutes)."""
    _require_ray(require_or_skip)
    out = tmp_path / "new" / "o"
    result, seconds = _cli(["dataset", str(config_file), "--engine", "ray",
                            "--address", not_ray, "--out", str(out)])
    error = _one_error(result)
    assert f"Failed to connect to Ray cluster at {not_ray}" in error
    assert "RAY_AUTH_MODE=token" in error  # the fix for a head with token authentication
    assert seconds < 90, seconds  # one GCS attempt (~41 s measured), not Ray's 20
    assert not out.exists() and not out.parent.exists()


@pytest.mark.gl
def test_an_address_that_is_no_ray_leaves_a_partial_dataset_as_it_was(
        tmp_path, not_ray, config_file, renderer, monkeypatch):
    from synth.dataset.run import run_dataset

    out = tmp_path / "o"
    run_dataset(config_file, out, count=1, progress=False)
    before = {**_files(out), ".lock": (out / ".lock").read_bytes()}
    stat = {p: (out / p).stat().st_mtime_ns for p in before}
    # Ray's own per-attempt timeouts, shortened (read as Ray is imported in that process)
    monkeypatch.setenv("RAY_gcs_rpc_server_connect_timeout_s", "2")
    monkeypatch.setenv("RAY_py_gcs_connect_timeout_s", "3")
    result, _ = _cli(["dataset", str(config_file), "--engine", "ray", "--address", not_ray,
                      "--out", str(out)])
    assert "Failed to connect to Ray cluster" in _one_error(result)
    assert {**_files(out), ".lock": (out / ".lock").read_bytes()} == before
    assert {p: (out / p).stat().st_mtime_ns for p in before} == stat
