"""Benchmark logic for :func:`matcher.match`: census vs OpenCV StereoBM / StereoSGBM.

No CLI here (a thin command can call :func:`bench_match` and print :func:`format_rows`).
Timings are wall-clock medians (and minima) over ``repeats`` runs after one warm-up run of each
configuration (which also triggers numba compilation or cache loading), on a synthetic textured
pair with a known constant shift. The runs of one size are interleaved (round ``i`` times every
configuration once), so that load from other processes affects ours and OpenCV's alike.
"""

from __future__ import annotations

import gc
import time
import tracemalloc
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import cv2
import numpy as np

from matcher.match import match

__all__ = ["ISAS", "BenchRow", "bench_match", "bench_match_isas", "format_rows", "peak_memory",
           "textured_pair"]

#: (label, method, window) of the runs timed by :func:`bench_match`.
RUNS: tuple[tuple[str, str, int], ...] = (
    ("CT 5x5", "ct", 5),
    ("CT 9x9", "ct", 9),
    ("CT 21x21", "ct", 21),
    ("SCT 21x21", "sct", 21),
    ("StereoBM 9", "bm", 9),
    ("StereoSGBM 5", "sgbm", 5),
)


@dataclass(frozen=True)
class BenchRow:
    """One timing: ``seconds`` (median) and ``best`` (fastest run), the median's ratios to the SGBM
    and BM runs of the same size, and the share of pixels within 1 px of the true shift
    (excluding the left band ``x < max_disparity``)."""

    label: str
    width: int
    height: int
    max_disparity: int
    seconds: float
    ratio_sgbm: float
    ratio_bm: float
    accuracy: float
    best: float

    def keys(self):
        """Field names, so that a row can be used where a mapping (a table row) is expected."""
        return asdict(self).keys()

    def get(self, key: str, default: object = None) -> object:
        """The field ``key``, or ``default``."""
        return getattr(self, key, default)

    def __getitem__(self, key: str) -> object:
        if key not in self.keys():
            raise KeyError(key)
        return getattr(self, key)


def textured_pair(
    width: int, height: int, *, shift: int, rng: np.random.Generator | int | None = 0
) -> tuple[np.ndarray, np.ndarray]:
    """A synthetic rectified pair: multi-scale random texture, left = right shifted by ``shift``.

    Left pixel ``x`` shows what right pixel ``x - shift`` shows (plus independent noise of one
    grey level), so the true disparity is ``shift`` everywhere (``x >= shift``).

    Returns
    -------
    left, right : (height, width) uint8 arrays

    Examples
    --------
    >>> left, right = textured_pair(40, 30, shift=5, rng=1)
    >>> left.shape, right.dtype
    ((30, 40), dtype('uint8'))
    """
    gen = np.random.default_rng(rng)
    tex = np.zeros((height, width + shift), np.float64)
    for sigma, amp in ((0.0, 0.5), (1.5, 1.0), (4.0, 1.5), (12.0, 2.0)):
        layer = gen.standard_normal(tex.shape)
        if sigma > 0:
            layer = cv2.GaussianBlur(layer, (0, 0), sigma)
            layer /= layer.std() + 1e-12
        tex += amp * layer
    tex = (tex - tex.mean()) / tex.std() * 40.0 + 128.0
    left = tex[:, :width] + gen.normal(0.0, 1.0, (height, width))
    right = tex[:, shift : shift + width] + gen.normal(0.0, 1.0, (height, width))

    def to8(a: np.ndarray) -> np.ndarray:
        return np.clip(np.rint(a), 0, 255).astype(np.uint8)

    return to8(left), to8(right)


def _time_interleaved(fns: dict, repeats: int) -> dict[str, tuple[float, float]]:
    """``{name: (median, min)}`` wall-clock seconds; round ``i`` runs every ``fns`` entry once.

    Each function runs once first (warm-up: compile / load caches, OpenCV's thread pool).
    """
    for fn in fns.values():
        fn()
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {name: (float(np.median(t)), float(np.min(t))) for name, t in times.items()}


def bench_match(
    *,
    sizes: Sequence[tuple[int, int, int]] = ((640, 480, 64), (1280, 960, 128)),
    repeats: int = 3,
    rng: int = 0,
    matchers: Sequence[str] = (),
) -> list[BenchRow]:
    """Time the census matchers against OpenCV on synthetic pairs.

    Parameters
    ----------
    sizes : sequence of (width, height, max_disparity)
    repeats : int
        Timed runs per configuration (median and minimum reported), interleaved across the
        configurations of one size.
    rng : int
        Seed of the synthetic pair.
    matchers : sequence of str
        MATCHER strings (:func:`matcher.adapters.resolve_matcher`) timed beside :data:`RUNS`,
        interleaved with them, on the same pair given as (H, W, 3) uint8 RGB (the grey pair in
        every channel); the label is the string. A ``py:`` matcher's time is the caller's wall
        time, its child process's round trip included. A failure raises
        :class:`matcher.adapters.MatcherFailure`.

    Returns
    -------
    list of BenchRow
        One row per size and entry of :data:`RUNS`, then one per matcher.

    Examples
    --------
    >>> rows = bench_match(sizes=((64, 48, 16),), repeats=1)
    >>> [r.label for r in rows][:2]
    ['CT 5x5', 'CT 9x9']
    """
    from matcher.adapters import resolve_matcher

    resolved = [resolve_matcher(spec) for spec in matchers]
    rows: list[BenchRow] = []
    for width, height, n_disp in sizes:
        shift = n_disp // 3
        left, right = textured_pair(width, height, shift=shift, rng=rng)
        holder: dict[str, np.ndarray] = {}
        fns = {}
        for label, method, window in RUNS:

            def run(label=label, method=method, window=window):
                holder[label] = match(
                    left, right, method=method, window=window, max_disparity=n_disp
                ).disparity

            fns[label] = run
        rgb = [np.ascontiguousarray(np.repeat(g[:, :, None], 3, axis=2)) for g in (left, right)]
        for m in resolved:

            def run_user(m=m):
                holder[m.spec] = m(*rgb, max_disparity=n_disp)

            fns[m.spec] = run_user
        try:
            timed = _time_interleaved(fns, repeats)
        finally:
            for m in resolved:
                m.close()
        measured = {}
        for label, (seconds, best) in timed.items():
            disp = holder[label][:, n_disp:]
            acc = float(np.mean(np.abs(disp - shift) <= 1.0))
            measured[label] = (seconds, best, acc)
        t_sgbm = measured["StereoSGBM 5"][0]
        t_bm = measured["StereoBM 9"][0]
        for label, (seconds, best, acc) in measured.items():
            rows.append(
                BenchRow(label, width, height, n_disp, seconds, seconds / t_sgbm,
                         seconds / t_bm, acc, best)
            )
    return rows


ISAS = ("native", "avx2")


def bench_match_isas(isa: str = "native", *, sizes: Sequence[tuple[int, int, int]] = (
        (640, 480, 64), (1280, 960, 128)), repeats: int = 3, rng: int = 0,
        matchers: Sequence[str] = ()) -> list[dict]:
    """:func:`bench_match` rows with an ``isa`` column: this CPU's build, and an AVX2-only one.

    ``isa="avx2"`` runs the same benchmark again in a fresh process whose numba target is an
    AVX2-only CPU (:data:`synth.jobs.bench.machine.AVX2_TARGET`: many users' CPUs have no
    AVX-512, and the Hamming kernels compile to ``vpopcntq`` where it exists); its ratios are to
    OpenCV in that same process. ``isa="native"`` runs this process's build only.
    """
    import json
    import os
    import subprocess
    import sys

    from synth.jobs.bench.machine import AVX2_TARGET, describe_machine

    if isa not in ISAS:
        raise ValueError(f"isa must be one of {', '.join(ISAS)}, got {isa!r}")
    native = describe_machine(backend=None).numba_target
    rows = [{"isa": native, **asdict(r)}
            for r in bench_match(sizes=sizes, repeats=repeats, rng=rng, matchers=matchers)]
    if isa == "avx2":
        code = ("import json, sys; from dataclasses import asdict\n"
                "from synth.jobs.bench.match import bench_match\n"
                "from synth.jobs.bench.machine import describe_machine\n"
                f"rows = bench_match(sizes={tuple(map(tuple, sizes))!r}, repeats={repeats}, "
                f"rng={rng}, matchers={tuple(matchers)!r})\n"
                "print(json.dumps([describe_machine(backend=None).numba_target,"
                " [asdict(r) for r in rows]]))\n")
        out = subprocess.run([sys.executable, "-c", code], env={**os.environ, **AVX2_TARGET},
                             capture_output=True, text=True, check=False)
        if out.returncode != 0:
            raise RuntimeError(f"the AVX2 benchmark process failed:\n{out.stderr.strip()}")
        target, avx2_rows = json.loads(out.stdout.strip().splitlines()[-1])
        rows += [{"isa": target, **r} for r in avx2_rows]
    return rows


def peak_memory(
    *, width: int = 1280, height: int = 960, max_disparity: int = 256, window: int = 21,
    method: str = "ct", aggregate: int | None = None, lr_check: bool = False,
    matcher: str | None = None,
) -> dict[str, float]:
    """Peak memory of one census match (or of a MATCHER string's ``matcher``, called with the
    RGB pair): numpy allocations (tracemalloc) and process RSS growth.

    numba's per-worker buffers are allocated by numba's runtime, which tracemalloc does not see;
    the RSS growth (psutil, sampled in a thread) covers them.

    Returns
    -------
    dict
        ``tracemalloc_peak_mb`` and ``rss_peak_growth_mb`` (MiB), and ``seconds``.

    Examples
    --------
    >>> m = peak_memory(width=64, height=48, max_disparity=16, window=5)
    >>> m["tracemalloc_peak_mb"] > 0
    True
    """
    import threading

    import psutil

    left, right = textured_pair(width, height, shift=max_disparity // 3, rng=0)
    kwargs = dict(method=method, window=window, max_disparity=max_disparity,
                  aggregate=aggregate, lr_check=lr_check)
    if matcher is not None:
        from matcher.adapters import resolve_matcher

        resolved = resolve_matcher(matcher)
        left, right = (np.ascontiguousarray(np.repeat(g[:, :, None], 3, axis=2))
                       for g in (left, right))

        def run(l_img: np.ndarray, r_img: np.ndarray, n_disp: int) -> None:
            resolved(l_img, r_img, max_disparity=n_disp)
    else:
        def run(l_img: np.ndarray, r_img: np.ndarray, n_disp: int) -> None:
            match(l_img, r_img, **{**kwargs, "max_disparity": n_disp,
                                   "window": min(window, 63)})
    run(left[:64, :128], right[:64, :128], 16)  # compile / load
    gc.collect()
    proc = psutil.Process()
    base = proc.memory_info().rss
    peak = [base]
    stop = threading.Event()

    def sample() -> None:
        while not stop.is_set():
            peak[0] = max(peak[0], proc.memory_info().rss)
            time.sleep(0.002)

    sampler = threading.Thread(target=sample, daemon=True)
    tracemalloc.start()
    sampler.start()
    t0 = time.perf_counter()
    run(left, right, max_disparity)
    seconds = time.perf_counter() - t0
    stop.set()
    sampler.join()
    _, traced = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {
        "tracemalloc_peak_mb": traced / 2**20,
        "rss_peak_growth_mb": (peak[0] - base) / 2**20,
        "seconds": seconds,
    }


def format_rows(rows: Sequence[BenchRow]) -> str:
    """A Markdown table of benchmark rows.

    Examples
    --------
    >>> row = BenchRow("CT 5x5", 64, 48, 16, 0.001, 0.5, 1.0, 0.99, 0.0009)
    >>> print(format_rows([row]).splitlines()[2])
    | CT 5x5 | 64x48 | 16 | 1.0 | 0.9 | 0.50 | 1.00 | 99.0 |
    """
    lines = [
        "| run | size | D | median ms | best ms | / SGBM | / BM | % within 1 px |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.label} | {r.width}x{r.height} | {r.max_disparity} | "
            f"{r.seconds * 1e3:.1f} | {r.best * 1e3:.1f} | {r.ratio_sgbm:.2f} | {r.ratio_bm:.2f} | "
            f"{r.accuracy * 100:.1f} |"
        )
    return "\n".join(lines)
