"""Benchmark jobs and their tables (``stereoforge bench ...``).

Tables are printed and written as Markdown and CSV (atomically), the Markdown headed by the machine
they ran on (:mod:`synth.jobs.bench.machine`). Speed targets live here, never in
timed unit tests.
"""

from __future__ import annotations

import csv
import functools
import io
import json
import resource
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path


from synth._util.progress import progress as progress_bar
from synth.jobs.bench.machine import MachineInfo, describe_machine

__all__ = ["parse_sizes", "bench_render", "format_markdown", "write_table"]


def parse_sizes(text: str) -> list[tuple[int, int]]:
    """Parse ``"640x480,1280x960"`` into ``[(640, 480), (1280, 960)]``.

    Examples
    --------
    >>> parse_sizes("640x480, 32x24")
    [(640, 480), (32, 24)]
    """
    sizes = []
    for item in text.split(","):
        parts = item.strip().lower().split("x")
        if len(parts) != 2 or not all(p.isdigit() and int(p) > 0 for p in parts):
            raise ValueError(f"bad size {item.strip()!r}: expected WIDTHxHEIGHT, e.g. 640x480")
        sizes.append((int(parts[0]), int(parts[1])))
    return sizes


def _peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB


def bench_render(
    *,
    sizes: Sequence[tuple[int, int]] = ((640, 480), (1280, 960)),
    pairs: int = 20,
    presets: Sequence[str] | None = None,
    backend: str = "auto",
    threads: int | None = 0,
    progress: bool = False,
) -> list[dict]:
    """Time scene building, rendering (colour + exact GT + masks) and writing, per preset and size.

    Each pair uses a new seed (0, 1, ...), so ``flying`` changes layout; everything runs in this
    process with one GL context per size. ``pairs_per_cpu_s`` divides by the process CPU time
    (all threads, including llvmpipe's), i.e. the throughput of one core. Files are written as
    the dataset job writes them: atomically (temporary name, then rename), without fsync, and
    without ``preview.png``.

    ``threads`` is llvmpipe's rasterizer thread count (see :class:`synth.render.Renderer`); the
    default 0 renders in the calling thread, so the process uses one core, as each worker of
    ``stereoforge dataset`` does. ``None`` keeps the driver's default (one thread per core:
    faster in wall time, ~15 % more CPU per pair). Fixed per process.

    Returns
    -------
    list of dict
        One row per (preset, size).
    """
    from scenes import get_preset, list_presets
    from synth.write.export import write_pair
    from synth.pair import render_pair
    from synth.render.renderer import Renderer
    from synth.camera.rig import StereoRig

    names = list(presets) if presets is not None else [name for name, _ in list_presets()]
    rows = []
    jobs = [(w, h, name) for (w, h) in sizes for name in names]
    bar = progress_bar(total=len(jobs) * pairs, desc="bench render", unit="pair", enabled=progress)
    for w, h in sizes:
        rig = StereoRig.default(w, h)
        with Renderer(w, h, backend=backend, threads=threads) as renderer, \
                tempfile.TemporaryDirectory() as tmp:
            for name in names:  # warm-up: shader variants compile once per process
                render_pair(get_preset(name, seed=0), rig, renderer=renderer)
            for name in names:
                build = draw = write = 0.0
                cpu0, wall0 = time.process_time(), time.perf_counter()
                for i in range(pairs):
                    t0 = time.perf_counter()
                    spec = get_preset(name, seed=i)
                    t1 = time.perf_counter()
                    pair = render_pair(spec, rig, renderer=renderer)
                    t2 = time.perf_counter()
                    out = Path(tmp) / f"{name}-{i}"
                    out.mkdir()
                    write_pair(pair, out, scene=spec, seed=i, preview=False, fsync=False)
                    t3 = time.perf_counter()
                    build, draw, write = build + t1 - t0, draw + t2 - t1, write + t3 - t2
                    bar.update()
                wall = time.perf_counter() - wall0
                cpu = time.process_time() - cpu0
                rows.append({
                    "preset": name,
                    "size": f"{w}x{h}",
                    "pairs": pairs,
                    "threads": "auto" if threads is None else threads,
                    "pairs_per_s": pairs / wall,
                    "pairs_per_cpu_s": pairs / cpu,
                    "build_ms": 1e3 * build / pairs,
                    "render_ms": 1e3 * draw / pairs,
                    "write_ms": 1e3 * write / pairs,
                    "peak_rss_mb": _peak_rss_mb(),
                })
    bar.close()
    return rows


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 10 else f"{value:.1f}"
    return str(value)


def format_markdown(rows: Sequence[dict]) -> str:
    """A Markdown table of ``rows`` (the keys of the first row are the columns).

    Examples
    --------
    >>> print(format_markdown([{"a": 1, "b": 2.5}]))
    | a | b |
    |---|---|
    | 1 | 2.5 |
    """
    if not rows:
        return "(no rows)"
    keys = list(rows[0].keys())
    lines = ["| " + " | ".join(keys) + " |", "|" + "|".join("---" for _ in keys) + "|"]
    lines += ["| " + " | ".join(_cell(r.get(k, "")) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def write_table(rows: Sequence, out: Path, name: str, *,
                machine: MachineInfo | None = None) -> str:
    """Write ``rows`` to ``out/<name>.md`` and ``out/<name>.csv`` atomically; return the Markdown.

    ``rows`` are dicts or dataclass instances (one per table row, same fields). The Markdown
    starts with the machine it ran on (``machine``, default :func:`describe_machine` of this
    process), which is also written to ``out/<name>.machine.json``; the CSV holds the rows only.
    """
    import dataclasses

    from matcher.io import atomic_write_bytes

    info = machine if machine is not None else _this_machine()
    rows = [dataclasses.asdict(r) if dataclasses.is_dataclass(r) else dict(r) for r in rows]
    out.mkdir(parents=True, exist_ok=True)
    text = info.markdown() + "\n\n" + format_markdown(rows)
    buf = io.StringIO()
    if rows:
        writer = csv.DictWriter(buf, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)
    atomic_write_bytes(out / f"{name}.md", (text + "\n").encode())
    atomic_write_bytes(out / f"{name}.csv", buf.getvalue().encode())
    atomic_write_bytes(out / f"{name}.machine.json",
                       (json.dumps(info.to_dict(), indent=2) + "\n").encode())
    return text + f"\n\nwritten: {out / (name + '.md')}, {out / (name + '.csv')}"


@functools.cache
def _this_machine() -> MachineInfo:
    return describe_machine()
