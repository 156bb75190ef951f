"""Paired differences of a validate run: the matcher against each reference and a baseline.

For two matchers A and B, an axis and a region, the paired differences are ``bad-2(A) -
bad-2(B)`` over every sample both were scored on (an axis value and seed, or a real scene), in
percentage points. :func:`difference_table` gives, per axis x region, their mean and the half
width of the 95 % t-interval ``t(0.975, n - 1) s / sqrt(n)``, and the verdict: **worse** when the
interval lies above 0, **better** when below, **no clear difference** when it holds 0, **too
few pairs** when n < 2 (a single real scene: the difference alone). Real scenes appear twice:
pooled as the axis ``real`` (the scenes are its samples), and one row per scene.

:func:`regressions` picks the rows of a baseline comparison that ``--fail-on regression``
fails on: worse by more than a number of points with the interval above 0. The table is
written as ``differences.csv`` (:data:`COLUMNS`).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

__all__ = ["COLUMNS", "HEADLINE", "read_results", "t_interval", "paired_differences",
           "difference_table", "regressions", "differences_csv", "describe_row"]

#: The metric compared (a results.csv column; fractions there, points here).
HEADLINE = "bad_2"
#: Columns of differences.csv.
COLUMNS = ("reference", "axis", "scene", "region", "n", "mean", "half_width", "verdict")
_REGIONS = ("all", "nonocc", "occluded", "textureless", "discontinuity")
_REAL = "real"
_FLOATS = ("value", "bad_0_5", "bad_1", "bad_2", "bad_4", "avgerr", "rms", "a50", "a90", "a99",
           "coverage", "seconds", "mpix_disp_per_s")


def read_results(path: Path) -> list[dict]:
    """The rows of a ``results.csv``: numbers as floats, empty cells None, the rest strings
    (a missing ``scene`` column, of folders written before it, reads as empty)."""
    with Path(path).open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        r.setdefault("scene", "")
        for k in _FLOATS:
            r[k] = float(r[k]) if r.get(k) not in (None, "") else None
    return rows


def t_interval(values: Sequence[float]) -> tuple[float, float, int]:
    """``(mean, half width of the 95 % t-interval, n)``; the half width is NaN when n < 2.

    Examples
    --------
    >>> m, h, n = t_interval([1.0, 2.0, 3.0])
    >>> round(m, 3), round(h, 3), n
    (2.0, 2.484, 3)
    """
    v = np.asarray(list(values), dtype=np.float64)
    if v.size == 0:
        return math.nan, math.nan, 0
    if v.size < 2:
        return float(v.mean()), math.nan, 1
    from scipy.stats import t

    half = float(t.ppf(0.975, v.size - 1) * v.std(ddof=1) / math.sqrt(v.size))
    return float(v.mean()), half, int(v.size)


def _key(value: object) -> str:
    """A value or seed as read back from results.csv or as run (4, 4.0 and "4" alike)."""
    if value is None or value == "":
        return ""
    try:
        return repr(float(value))  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(value)


def _index(rows: Sequence[dict], metric: str) -> dict[tuple[str, str], dict[tuple, dict]]:
    """``{(axis, region): {(value, seed, scene): {matcher: metric}}}`` of the scored rows."""
    index: dict[tuple[str, str], dict[tuple, dict]] = {}
    for r in rows:
        if r[metric] is not None:
            key = (_key(r["value"]), _key(r["seed"]), str(r.get("scene", "")))
            index.setdefault((r["axis"], r["region"]), {}).setdefault(key, {})[r["matcher"]] = \
                r[metric]
    return index


def _paired(samples: dict[tuple, dict], a: str, b: str, scene: str | None) -> list[float]:
    return [m[a] - m[b] for key, m in sorted(samples.items())
            if a in m and b in m and (scene is None or key[2] == scene)]


def paired_differences(rows: Sequence[dict], a: str, b: str, *, axis: str, region: str,
                       metric: str = HEADLINE, scene: str | None = None) -> list[float]:
    """``metric(a) - metric(b)`` for every sample (value, seed, scene) of ``axis`` and
    ``region`` both scored; only scene ``scene`` if given."""
    return _paired(_index(rows, metric).get((axis, region), {}), a, b, scene)


def _verdict(mean: float, half: float) -> str:
    if math.isnan(half):
        return "too few pairs"
    if mean - half > 0:
        return "worse"
    if mean + half < 0:
        return "better"
    return "no clear difference"


def difference_table(rows: Sequence[dict], matcher: str, others: Sequence[str]) -> list[dict]:
    """One row per other matcher x axis (then real scene) x region with paired differences.

    Axes come in the order of ``rows`` (results.csv's: the registry order), ``real`` last and
    then its scenes. Each row: ``reference, axis, scene`` (empty but for a single real scene),
    ``region, n, mean, half_width`` (points; NaN half width when n < 2) and ``verdict``.
    """
    axes = list(dict.fromkeys(r["axis"] for r in rows if r["axis"] != _REAL))
    scenes = list(dict.fromkeys(r.get("scene", "") for r in rows if r["axis"] == _REAL))
    groups = [(a, None) for a in axes] + ([(_REAL, None)] if scenes else []) + [
        (_REAL, s) for s in scenes]
    index = _index(rows, HEADLINE)
    table = []
    for other in others:
        for axis, scene in groups:
            for region in _REGIONS:
                diffs = _paired(index.get((axis, region), {}), matcher, other, scene)
                if not diffs:
                    continue
                m, h, n = t_interval([100.0 * d for d in diffs])
                table.append({"reference": other, "axis": axis, "scene": scene or "",
                              "region": region, "n": n, "mean": m, "half_width": h,
                              "verdict": _verdict(m, h)})
    return table


def regressions(table: Sequence[dict], reference: str, points: float) -> list[dict]:
    """The rows against ``reference`` worse by more than ``points`` with the interval above 0
    (single real scenes, without an interval, never count; the pooled ``real`` row does)."""
    return [r for r in table if r["reference"] == reference and not r["scene"]
            and r["verdict"] == "worse" and r["mean"] > points]


def describe_row(row: dict) -> str:
    """``axis / region +3.1 ± 0.9`` (points), e.g. for an error message.

    Examples
    --------
    >>> describe_row({"axis": "noise", "scene": "", "region": "all", "mean": 3.14,
    ...               "half_width": 0.9})
    'noise / all +3.1 ± 0.9'
    """
    where = row["scene"] or row["axis"]
    half = "" if math.isnan(row["half_width"]) else f" ± {row['half_width']:.1f}"
    return f"{where} / {row['region']} {row['mean']:+.1f}{half}"


def differences_csv(table: Sequence[dict]) -> bytes:
    """``differences.csv``: :data:`COLUMNS`, floats as Python's ``repr`` (empty for NaN)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in table:
        writer.writerow(["" if isinstance(row[c], float) and math.isnan(row[c])
                         else repr(row[c]) if isinstance(row[c], float) else row[c]
                         for c in COLUMNS])
    return buf.getvalue().encode()
