"""``tools/gpu_check.sh`` runs its steps here too (llvmpipe), so it works before GPU time is
spent on it: each step's output in one file, each step ending with exit status 0."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = [pytest.mark.gl, pytest.mark.slow]


def test_gpu_check_runs_every_step_on_this_machine(tmp_path, renderer):
    if shutil.which("timeout") is None:
        pytest.skip("the script needs coreutils' timeout, absent here")
    bin_dir = tmp_path / "bin"  # `stereoforge` and `python3` of this interpreter, first on PATH
    bin_dir.mkdir()
    (bin_dir / "stereoforge").write_text(
        f'#!/bin/sh\nexec "{sys.executable}" -c "import sys; from synth.cli import main; '
        f'sys.exit(main())" "$@"\n')
    (bin_dir / "python3").write_text(f'#!/bin/sh\nexec "{sys.executable}" "$@"\n')
    for script in bin_dir.iterdir():
        script.chmod(0o755)
    out = tmp_path / "out"
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}"}
    run = subprocess.run(["bash", str(ROOT / "tools" / "gpu_check.sh"), str(out), "1", "2"],
                         cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    steps = ["gl", "gl_overheads", "golden", "ground_truth", "bench", "bench_yield"]
    assert run.stdout.splitlines() == [line for line in run.stdout.splitlines()
                                       if line.split(":")[0] in steps]
    for step in steps:
        text = (out / f"{step}.txt").read_text()
        assert text.splitlines()[-1].startswith("exit status 0 after"), (step, text[-2000:])
    assert "egl |" in (out / "gl.txt").read_text()
    overheads = (out / "gl_overheads.txt").read_text()
    for operation in ("finish", "dispatch", "dispatch+finish", "upload", "mipmap", "readback"):
        assert f"| {operation} | " in overheads, overheads
    bench = (out / "bench.txt").read_text()  # the rates' and the stages' tables
    assert "| flying | 960x540 | isal |" in bench and "| flying | 960x540 | stored |" in bench
    assert "| flying | 960x540 | middlebury | isal | local | 1 |" in bench
    # the last worker count, and half as many again (at least one more)
    rows = [line.split(" | ")[5] for line in (out / "bench_yield.txt").read_text().splitlines()
            if line.startswith("| flying | 960x540 | middlebury |")]
    assert rows == ["1", "2"], rows
    assert len(list(out.iterdir())) <= 8  # what a device run brings back


@pytest.mark.parametrize("args, words", [
    (["1,x"], "Error: WORKERS must be worker counts >= 1 separated by commas"),
    (["0"], "Error: WORKERS must be worker counts"),
    (["2", "many"], "Error: COUNT must be an integer >= 1"),
    (["2", "4", "gzip"], "Error: DEFLATES must be PNG deflates"),
])
def test_gpu_check_refuses_bad_arguments_before_any_step(tmp_path, args, words):
    run = subprocess.run(["bash", str(ROOT / "tools" / "gpu_check.sh"), str(tmp_path / "o"),
                          *args], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and run.stdout == "", (run.stdout, run.stderr)
    assert run.stderr.strip().splitlines() == [run.stderr.strip()] and words in run.stderr
    assert not (tmp_path / "o").exists()


def test_gpu_check_exits_non_zero_when_a_step_fails(tmp_path):
    bin_dir = tmp_path / "bin"  # every step's program fails at once
    bin_dir.mkdir()
    for name in ("stereoforge", "python3"):
        (bin_dir / name).write_text("#!/bin/sh\nexit 3\n")
        (bin_dir / name).chmod(0o755)
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}"}
    run = subprocess.run(["bash", str(ROOT / "tools" / "gpu_check.sh"), str(tmp_path / "o"),
                          "1", "2"], cwd=ROOT, env=env, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 1, run.stderr
    assert "gpu_check: 6 step(s) failed: gl gl_overheads golden ground_truth bench bench_yield" \
        in run.stderr
