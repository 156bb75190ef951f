"""`stereoforge bench render`: rows, files and option errors (speed itself is not tested)."""

from __future__ import annotations

import csv
import json

import pytest
from click.testing import CliRunner

from synth.jobs.bench.render import bench_render, write_table
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
    header, table = text.split("\n\n", 1)
    assert table.startswith("| preset | size | pairs | threads |")
    assert [line.split(":")[0] for line in header.splitlines()] == [
        "- cpu", "- cores", "- numba target", "- opencv dispatch", "- gl renderer"]
    machine = json.loads((tmp_path / "render.machine.json").read_text())
    assert machine["gl_renderer"] == renderer.gl_renderer
    assert machine["cores"] >= 1 and machine["cpu"]
    with open(tmp_path / "render.csv") as f:
        assert [r["preset"] for r in csv.DictReader(f)] == ["fronto_plane", "boxes"]


def test_bench_render_cli_rejects_bad_threads(tmp_path) -> None:
    result = CliRunner().invoke(main, ["bench", "render", "--threads", "many",
                                       "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert "--threads must be 'auto' or an int >= 0, got 'many'" in result.output
    assert not any(tmp_path.iterdir())


def test_machine_names_the_simd_level_numba_compiles_for() -> None:
    from synth.jobs.bench.machine import AVX2_TARGET, simd_level

    assert simd_level(AVX2_TARGET["NUMBA_CPU_FEATURES"]) == "AVX2"
    assert simd_level("+sse2,+sse4.2") == "SSE4.2"
    assert simd_level("+avx2,+avx512f,+avx512bw,-avx512vpopcntdq") == "AVX-512"
    assert simd_level("-sse2") == "none above SSE2"


def test_machine_reports_an_environment_set_numba_target() -> None:
    import os
    import subprocess
    import sys

    from synth.jobs.bench.machine import AVX2_TARGET

    env = {**os.environ, **AVX2_TARGET}
    code = "from synth.jobs.bench.machine import describe_machine; print(describe_machine(backend=None).numba_target)"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "haswell (NUMBA_CPU_NAME), AVX2"


@pytest.mark.slow
def test_bench_match_times_an_avx2_build_beside_the_native_one() -> None:
    from synth.jobs.bench.match import RUNS, bench_match_isas

    rows = bench_match_isas("avx2", sizes=((64, 48, 16),), repeats=1)
    isas = [r["isa"] for r in rows]
    assert len(rows) == 2 * len(RUNS) and len(set(isas)) == 2
    assert isas[-1] == "haswell (NUMBA_CPU_NAME), AVX2"
    for r in rows:  # every build's ratios are to OpenCV's SGBM of its own process
        assert r["seconds"] > 0 and (r["label"] != "StereoSGBM 5" or r["ratio_sgbm"] == 1.0)


def test_bench_match_refuses_an_unknown_isa() -> None:
    from synth.jobs.bench.match import bench_match_isas

    with pytest.raises(ValueError, match="isa must be one of native, avx2, got 'sse'"):
        bench_match_isas("sse")
    result = CliRunner().invoke(main, ["bench", "match", "--isa", "sse"])
    assert result.exit_code == 2 and "'sse' is not one of 'native', 'avx2'" in result.output
