"""Engines: argument checks, the in-process loop, and Ray (optional extra, slow)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from synth.engine import ray_available, run_tasks


class _Square:
    width, height, backend = 16, 16, "auto"

    def __call__(self, index, renderer):
        return {"square": index * index, "backend": renderer.backend}


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


_FAULTS = """
import resource, sys
import numpy as np
if sys.argv[1] == "tuned":
    from synth.engine import _tune_malloc
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


@pytest.mark.gl
@pytest.mark.slow
def test_ray_engine_writes_the_same_bytes_as_local(tmp_path, renderer, require_or_skip):
    _require_ray(require_or_skip)
    import ray

    from synth.config import loads_config
    from synth.dataset import SampleError, run_dataset

    cfg = loads_config("seed = 2\ncount = 4\n[rig]\nwidth = 32\nheight = 24\n[scene]\n"
                       'base = {choice = ["fronto_plane", "flying"]}\noccluders = 1\n'
                       "[photometric]\nnoise_sigma = 2.0\n")
    run_dataset(cfg, out=tmp_path / "local", workers=1, progress=False)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        run_dataset(cfg, out=tmp_path / "ray", workers=2, engine="ray", progress=False)
        # a failing sample comes back as the SampleError naming it (far = 5 m < flying's wall)
        bad = loads_config("seed = 2\ncount = 4\n[rig]\nwidth = 32\nheight = 24\n"
                           "far = 5.0\n[scene]\nbase = 'flying'\n")
        with pytest.raises(SampleError, match=r"sample \d \(seed \d+\) failed: ValueError"):
            run_dataset(bad, out=tmp_path / "bad", workers=2, engine="ray", progress=False)
        assert not [p for p in (tmp_path / "bad").iterdir() if p.name[0].isdigit()]
    finally:
        ray.shutdown()
    local, remote = tmp_path / "local", tmp_path / "ray"
    files = sorted(str(p.relative_to(local)) for p in local.rglob("*") if p.is_file())
    assert files == sorted(str(p.relative_to(remote)) for p in remote.rglob("*") if p.is_file())
    for f in files:
        assert Path(local, f).read_bytes() == Path(remote, f).read_bytes(), f
