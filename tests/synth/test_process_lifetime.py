"""Killing the main process alone (kill -9, the OOM killer, a CI timeout) ends all its children.

The fork server dies with the main process and the workers with the fork server
(``PR_SET_PDEATHSIG``); multiprocessing's resource tracker sees its pipe close and exits. Before,
the fork server, the tracker and both workers (~830 MB) outlived the main process and kept
rendering samples without holding the dataset's lock.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

_CLI = [sys.executable, "-c", "from synth.cli import main; main()"]


def _live(procs: list[psutil.Process]) -> list[psutil.Process]:
    alive = []
    for p in procs:
        try:
            if p.is_running() and p.status() != psutil.STATUS_ZOMBIE:
                alive.append(p)
        except psutil.NoSuchProcess:
            pass
    return alive


def _outputs(out: Path) -> set[str]:
    return {str(p.relative_to(out)) for p in out.rglob("*") if ".tmp" not in str(p)} \
        if out.exists() else set()


def _kill_main_alone(argv: list[str], out: Path, log: Path) -> tuple[int, list[psutil.Process]]:
    """Start ``argv``, wait for its 2 workers and a first output, SIGKILL the main pid only."""
    with open(log, "wb") as sink:
        proc = subprocess.Popen(argv, stdout=sink, stderr=sink)
    main = psutil.Process(proc.pid)
    try:
        deadline = time.monotonic() + 120
        while True:
            assert proc.poll() is None, log.read_text()[-2000:]
            assert time.monotonic() < deadline, "no 2 workers and output within 120 s"
            family = _live(main.children(recursive=True))
            workers = [p for p in family if p.ppid() != proc.pid]  # forked by the fork server
            if len(workers) >= 2 and len(_outputs(out)) > 2:
                break
            time.sleep(0.05)
        os.kill(proc.pid, signal.SIGKILL)  # the main process alone, as the OOM killer does
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return len(family), family


@pytest.mark.gl
@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG: Linux")
@pytest.mark.parametrize("command", ["dataset", "study"])
def test_sigkill_of_the_main_process_ends_every_child(command, tmp_path):
    out = tmp_path / "out"
    argv = {"dataset": [*_CLI, "dataset", "planes", "--workers", "2", "--count", "200"],
            "study": [*_CLI, "study", "texture-window", "--workers", "2"]}[command]
    before, family = _kill_main_alone([*argv, "--out", str(out)], out, tmp_path / "log")
    # the fork server, the resource tracker and 2 workers
    assert before >= 4, [p.cmdline() for p in family]
    deadline = time.monotonic() + 10
    while _live(family) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = _live(family)
    try:
        assert not left, [" ".join(p.cmdline())[:100] for p in left]
    finally:
        for p in left:  # our own children: never leave them running after a failure
            p.kill()
    files = _outputs(out)
    time.sleep(1.5)
    assert _outputs(out) == files  # nothing written after the main process died


_CHAIN = """
import os, sys, time
from synth.dataset.engine.tasks import die_with_parent
if sys.argv[1] == "child":
    die_with_parent(also=int(sys.argv[2]))
    if len(sys.argv) > 3:
        open(sys.argv[3], "w").close()  # armed
    time.sleep(60)
else:
    import subprocess
    subprocess.Popen([sys.executable, "-c", sys.argv[2], "child", str(os.getppid()), sys.argv[3]])
    time.sleep(60)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG: Linux")
def test_die_with_parent_kills_the_child_with_its_parent_or_at_once(tmp_path):
    # the chain head (`also`) already gone: the child exits at once, status 1
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    late = subprocess.run([sys.executable, "-c", _CHAIN, "child", str(gone.pid)], timeout=60,
                          capture_output=True, text=True)
    assert late.returncode == 1 and late.stdout == ""
    # a middle process killed: its child (armed with PR_SET_PDEATHSIG) follows it
    armed = tmp_path / "armed"
    middle = subprocess.Popen([sys.executable, "-c", _CHAIN, "parent", _CHAIN, str(armed)])
    try:
        deadline = time.monotonic() + 60
        while not armed.exists():
            assert time.monotonic() < deadline and middle.poll() is None
            time.sleep(0.02)
        (child,) = psutil.Process(middle.pid).children()
        middle.kill()
        middle.wait()
        child.wait(timeout=10)  # raises psutil.TimeoutExpired if the child outlives its parent
        assert not _live([child])
    finally:
        if middle.poll() is None:
            middle.kill()
            middle.wait()
