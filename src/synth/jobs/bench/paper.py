"""Timing of the seed paper's methods (CTHW, AWCT, AWSCT) against CT/SCT, same run, same pair.

A benchmark, not a test: numbers depend on the machine and its load. Each method runs once to
compile (numba) and then ``repeats`` times, interleaved with the other methods (round ``i`` runs
every method once, so that load from other processes affects all alike); the minimum and the
median wall time are reported.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from matcher.adaptive import match_awct
from matcher.cthw import match_cthw
from matcher.match import match

__all__ = ["bench_pair", "bench_paper_methods"]


def bench_pair(
    shape: tuple[int, int] = (480, 640), *, shift: int = 10, rng: np.random.Generator | int | None = 0
) -> tuple[np.ndarray, np.ndarray]:
    """A textured uint8 pair with flat-ish patches and steps (so Canny finds edges).

    The left view is the right one shifted by ``shift`` pixels (left ``x`` matches right
    ``x - shift``).

    Examples
    --------
    >>> left, right = bench_pair((16, 32), shift=2)
    >>> left.shape, bool((left[:, 2:] == right[:, :-2]).all())
    ((16, 32), True)
    """
    from scipy.ndimage import gaussian_filter

    gen = np.random.default_rng(rng)
    h, w = shape
    base = gaussian_filter(gen.random((h, w + shift)), 1.5)
    base = (base - base.min()) / (base.max() - base.min()) * 120 + 40
    for _ in range(12):  # rectangles of other brightness: steps for the edge detector
        y0, x0 = gen.integers(0, h - 8), gen.integers(0, w + shift - 8)
        hh, ww = gen.integers(8, max(9, h // 3)), gen.integers(8, max(9, w // 3))
        base[y0 : y0 + hh, x0 : x0 + ww] += gen.uniform(-40, 60)
    full = np.clip(base, 0, 255).astype(np.uint8)
    return full[:, :w].copy(), full[:, shift:].copy()


def _interleaved(fns: dict, repeats: int) -> dict[str, tuple[float, float, object]]:
    """``{name: (min, median, result)}`` seconds over ``repeats`` interleaved rounds."""
    out = {name: fn() for name, fn in fns.items()}  # warm-up (numba compile / cache load)
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            t = time.perf_counter()
            out[name] = fn()
            times[name].append(time.perf_counter() - t)
    return {n: (float(np.min(t)), float(np.median(t)), out[n]) for n, t in times.items()}


def bench_paper_methods(
    *,
    shape: tuple[int, int] = (480, 640),
    max_disparity: int = 64,
    max_window: int = 21,
    cthw_windows: tuple[int, ...] = (9, 21),
    repeats: int = 5,
    canny_impls: tuple[str, ...] = ("skimage", "opencv"),
) -> list[dict[str, object]]:
    """Time AWCT/AWSCT against CT/SCT at ``max_window`` and CTHW against CT at the same window.

    AWCT/AWSCT are timed once per Canny implementation in ``canny_impls`` (see
    :func:`matcher.edges.canny_edges`; ``"skimage"`` is the default of
    :func:`matcher.adaptive.match_awct`).

    Returns
    -------
    list of dict
        One row per method: ``method``, ``window``, ``seconds`` (best of ``repeats``),
        ``median_seconds``, ``baseline`` (the method it is compared with), ``ratio`` (seconds /
        baseline's seconds, both best of ``repeats``), ``median_ratio`` (the same for the
        medians), ``census_comparisons``, ``reduction_ratio`` and ``canny`` (adaptive methods;
        ``None`` for the others, so that every row has the same keys).

    Examples
    --------
    >>> rows = bench_paper_methods(shape=(24, 40), max_disparity=8, max_window=7,
    ...                            cthw_windows=(5,), repeats=1)
    >>> [(r["method"], r["canny"]) for r in rows]  # doctest: +NORMALIZE_WHITESPACE
    [('ct', None), ('awct', 'skimage'), ('awct', 'opencv'), ('sct', None),
     ('awsct', 'skimage'), ('awsct', 'opencv'), ('ct', None), ('cthw', None)]
    """
    left, right = bench_pair(shape)
    d = max_disparity
    rows: list[dict[str, object]] = []

    def add(method, window, timing, baseline, base_timing, canny=None):
        seconds, median, res = timing
        row = {
            "method": method, "window": window, "seconds": seconds, "median_seconds": median,
            "baseline": baseline,
            "ratio": seconds / base_timing[0] if base_timing[0] else 1.0,
            "median_ratio": median / base_timing[1] if base_timing[1] else 1.0,
            "census_comparisons": res.ops.census_comparisons,
            "reduction_ratio": getattr(res, "reduction_ratio", None),
            "canny": canny,
        }
        rows.append(row)

    fns: dict[str, Callable[[], object]] = {}
    for base, adaptive, pattern in (("ct", "awct", "dense"), ("sct", "awsct", "sparse")):
        fns[f"{base} {max_window}"] = lambda b=base: match(
            left, right, method=b, window=max_window, max_disparity=d
        )
        for impl in canny_impls:
            fns[f"{adaptive} {max_window} {impl}"] = lambda p=pattern, c=impl: match_awct(
                left, right, max_window=max_window, max_disparity=d, pattern=p, canny_impl=c
            )
    for w in cthw_windows:
        fns[f"ct {w}"] = lambda w=w: match(left, right, window=w, max_disparity=d)
        fns[f"cthw {w}"] = lambda w=w: match_cthw(left, right, window=w, max_disparity=d)
    t = _interleaved(fns, repeats)
    for base, adaptive in (("ct", "awct"), ("sct", "awsct")):
        b = t[f"{base} {max_window}"]
        add(base, max_window, b, base, b)
        for impl in canny_impls:
            add(adaptive, max_window, t[f"{adaptive} {max_window} {impl}"], base, b, impl)
    for w in cthw_windows:
        b = t[f"ct {w}"]
        add("ct", w, b, "ct", b)
        add("cthw", w, t[f"cthw {w}"], "ct", b)
    return rows
