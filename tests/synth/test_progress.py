"""Progress output written to a log: a few plain lines, never one per update."""

from __future__ import annotations

import io
import os
import subprocess
import sys

import pytest

from synth._util.progress import LOG_SECONDS, LogProgress, progress


class _Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def test_log_lines_need_ten_seconds_and_ten_percent() -> None:
    clock, out = _Clock(), io.StringIO()
    bar = LogProgress(total=100, desc="dataset planes", unit="pair", file=out, clock=clock)
    for _ in range(100):  # 1 s per pair: a line every 10 pairs (10 s and 10 % both reached)
        clock.t += 1.0
        bar.update()
    bar.close()
    lines = out.getvalue().splitlines()
    assert len(lines) == 10 and lines[0] == "dataset planes: 10/100 pair (10 %), 10.0 s"
    assert lines[-1] == "dataset planes: 100/100 pair (100 %), 100.0 s"


def test_fast_updates_print_only_the_last_line() -> None:
    clock, out = _Clock(), io.StringIO()
    bar = LogProgress(total=1000, desc="d", file=out, clock=clock)
    for _ in range(1000):  # 1000 updates in 5 s: under 10 s, so one line at the end
        clock.t += 0.005
        bar.update()
    bar.close()
    bar.close()  # idempotent
    assert out.getvalue().splitlines() == ["d: 1000/1000 it (100 %), 5.0 s"]


def test_slow_updates_wait_for_ten_percent() -> None:
    clock, out = _Clock(), io.StringIO()
    bar = LogProgress(total=50, desc="d", file=out, clock=clock)
    for _ in range(4):  # 4 of 50 is under 10 %: no line however long it takes
        clock.t += 3 * LOG_SECONDS
        bar.update()
    assert out.getvalue() == ""
    clock.t += 1.0
    bar.update()
    assert out.getvalue().splitlines() == ["d: 5/50 it (10 %), 121.0 s"]


def test_iteration_and_initial_count() -> None:
    out = io.StringIO()
    items = list(LogProgress(range(3), desc="demo", unit="scene", initial=0, file=out))
    assert items == [0, 1, 2] and out.getvalue().startswith("demo: 3/3 scene (100 %)")


def test_progress_picks_plain_lines_off_a_terminal() -> None:
    assert not sys.stderr.isatty()  # pytest captures stderr
    assert isinstance(progress(total=3, desc="x"), LogProgress)
    assert not isinstance(progress(total=3, desc="x", enabled=False), LogProgress)


@pytest.mark.gl
def test_dataset_progress_in_a_log_file_is_a_few_lines(tmp_path, renderer) -> None:
    log = tmp_path / "log.txt"
    code = "import sys; from synth.cli import main; main(sys.argv[1:])"
    with open(log, "w") as f:
        subprocess.run([sys.executable, "-c", code, "dataset", "planes", "--count", "12",
                        "--out", str(tmp_path / "ds"), "--backend", renderer.backend],
                       stderr=f, stdout=subprocess.DEVNULL, check=True, env=dict(os.environ))
    lines = [ln for ln in log.read_text().splitlines() if ln.startswith("dataset planes")]
    assert 1 <= len(lines) <= 11, lines
    assert "\r" not in log.read_text() and lines[-1].startswith("dataset planes: 12/12 pair (100 %)")
