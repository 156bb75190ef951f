"""`stereoforge bench render`: rows, files and option errors (speed itself is not tested)."""

from __future__ import annotations

import csv

import pytest
from click.testing import CliRunner

from synth.jobs.bench_render import bench_render, write_table
from synth.cli import main
from synth.render.renderer import Renderer


@pytest.mark.gl
def test_bench_render_rows_and_table(tmp_path, renderer: Renderer) -> None:
    # threads=None: this test process already runs the driver with its default thread count
    rows = bench_render(sizes=[(64, 48)], pairs=2, presets=["fronto_plane", "boxes"],
                        backend=renderer.backend, threads=None)
    assert [r["preset"] for r in rows] == ["fronto_plane", "boxes"]
    for r in rows:
        assert r["size"] == "64x48" and r["pairs"] == 2 and r["threads"] == "auto"
        assert r["pairs_per_s"] > 0 and r["pairs_per_cpu_s"] > 0
        assert r["render_ms"] > 0 and r["write_ms"] > 0 and r["peak_rss_mb"] > 0
    text = write_table(rows, tmp_path, "render")
    assert text.startswith("| preset | size | pairs | threads |")
    with open(tmp_path / "render.csv") as f:
        assert [r["preset"] for r in csv.DictReader(f)] == ["fronto_plane", "boxes"]


def test_bench_render_cli_rejects_bad_threads(tmp_path) -> None:
    result = CliRunner().invoke(main, ["bench", "render", "--threads", "many",
                                       "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert "--threads must be 'auto' or an int >= 0, got 'many'" in result.output
    assert not any(tmp_path.iterdir())
