"""``report.html`` of a validate run: one self-contained page (every image a ``data:`` URI).

:func:`write_report` reads ``results.csv`` and ``properties.json`` of a validate folder (either may
be missing; the page says so) and writes, in order:

1. **Summary**: for each reference and each axis x region, the paired difference of bad-2
   (matcher minus reference, percentage points) over every (value, seed) both scored, as
   ``mean ± half width`` of the 95 % t-interval (``t(0.975, n - 1) s / sqrt(n)``). *Worse* when
   the interval lies above 0, *better* when below, otherwise *no clear difference*. A sample the
   matcher failed on scores bad-2 = 100 % there (no estimate anywhere), as in ``results.csv``.
2. **One plot per axis**: bad-2 against the axis value for the matcher and the references, one
   panel per region, mean over seeds with the 95 % t-interval as error bars (an SVG drawn here:
   matplotlib took seconds per figure, too slow for a quick run's dozen axes).
3. **Worst samples** of the matcher (highest bad-2 over ``all``): left view, ground truth,
   estimate (one colour bar, pixels) and ``|error|`` (its own colour bar), with a legend for
   pixels without ground truth and without estimate.
4. **Properties** of the battery (:mod:`synth.validate.properties`) with the counterexamples.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from matcher.io import atomic_write_bytes

__all__ = ["HEADLINE", "WORST_SAMPLES", "write_report", "paired_differences", "t_interval"]

#: The metric of the summary and the plots (a results.csv column; fractions, shown in %).
HEADLINE = "bad_2"
#: How many of the matcher's worst samples get error maps.
WORST_SAMPLES = 4
_REGIONS = ("all", "nonocc", "occluded", "textureless", "discontinuity")
_FLOATS = ("value", "bad_0_5", "bad_1", "bad_2", "bad_4", "avgerr", "rms", "a50", "a90", "a99",
           "coverage", "seconds", "mpix_disp_per_s")
_NO_GT_RGB = (0.78, 0.78, 0.78)
_NO_ESTIMATE_RGB = (1.0, 0.0, 1.0)


# --------------------------------------------------------------------------- numbers
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


def paired_differences(rows: Sequence[dict], a: str, b: str, *, axis: str, region: str,
                       metric: str = HEADLINE) -> list[float]:
    """``metric(a) - metric(b)`` for every (value, seed) of ``axis`` and ``region`` both scored."""
    index: dict[tuple, dict[str, float]] = {}
    for r in rows:
        if r["axis"] == axis and r["region"] == region and r[metric] is not None:
            index.setdefault((r["value"], r["seed"]), {})[r["matcher"]] = r[metric]
    return [m[a] - m[b] for _, m in sorted(index.items()) if a in m and b in m]


def _read_results(path: Path) -> list[dict]:
    with path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in _FLOATS:
            r[k] = float(r[k]) if r.get(k) not in (None, "") else None
    return rows


# --------------------------------------------------------------------------- pictures
def _png_uri(data: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _figure_uri(fig) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80, metadata={"Software": None})
    plt.close(fig)
    return _png_uri(buf.getvalue())


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")


def _svg_uri(svg: str) -> str:
    return "data:image/svg+xml;base64," + base64.b64encode(svg.encode("utf-8")).decode("ascii")


def _ticks(lo: float, hi: float, values: list[float]) -> list[float]:
    if len(values) <= 7:
        return values
    return [lo + (hi - lo) * k / 4 for k in range(5)]


def _axis_plot(rows: list[dict], axis: str, matchers: list[str]) -> str:
    """bad-2 against the axis value, one panel per region: an SVG (drawn here: fast, exact).

    Each point is the mean over seeds, its bar the 95 % t-interval (none for one seed).
    """
    regions = [g for g in _REGIONS if any(r["region"] == g and r["axis"] == axis
                                          and r[HEADLINE] is not None for r in rows)]
    series: dict[tuple[str, str], list[tuple[float, float, float]]] = {}
    for region in regions:
        for m in matchers:
            by_value: dict[float, list[float]] = {}
            for r in rows:
                if r["matcher"] == m and r["axis"] == axis and r["region"] == region \
                        and r[HEADLINE] is not None:
                    by_value.setdefault(r["value"], []).append(100 * r[HEADLINE])
            series[region, m] = [(v, *t_interval(by_value[v])[:2]) for v in sorted(by_value)]
    values = sorted({p[0] for pts in series.values() for p in pts})
    tops = [p[1] + (0 if math.isnan(p[2]) else p[2]) for pts in series.values() for p in pts]
    ymax = min(100.0, max(10.0, 10 * math.ceil(max(tops, default=10) / 10)))
    lo, hi = (values[0], values[-1]) if values else (0.0, 1.0)
    if hi == lo:
        lo, hi = lo - 0.5, hi + 0.5
    pw, ph, ml, mt, gap = 200, 130, 34, 34, 14
    width, height = ml + len(regions) * (pw + gap), mt + ph + 34

    def x(v: float, k: int) -> float:
        return ml + k * (pw + gap) + 6 + (v - lo) / (hi - lo) * (pw - 12)

    def y(v: float) -> float:
        return mt + ph - v / ymax * ph

    out = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{width}' height='{height}' "
           "font-family='sans-serif' font-size='9'><rect width='100%' height='100%' fill='white'/>"]
    lx = ml
    for j, m in enumerate(matchers):  # legend: one entry after the other
        label = html.escape(m + (" (validated)" if j == 0 else ""))
        out.append(f"<rect x='{lx}' y='4' width='10' height='3' fill='{_COLOURS[j % 6]}'/>"
                   f"<text x='{lx + 14}' y='9'>{label}</text>")
        lx += 30 + 5.5 * len(m + (" (validated)" if j == 0 else ""))
    for k, region in enumerate(regions):
        x0 = ml + k * (pw + gap)
        out.append(f"<text x='{x0 + pw / 2}' y='{mt - 6}' text-anchor='middle' "
                   f"font-weight='bold'>{region}</text><rect x='{x0}' y='{mt}' width='{pw}' "
                   f"height='{ph}' fill='none' stroke='#888'/>")
        for t in (0, ymax / 2, ymax):
            out.append(f"<line x1='{x0}' x2='{x0 + pw}' y1='{y(t)}' y2='{y(t)}' stroke='#eee'/>")
            if k == 0:
                out.append(f"<text x='{x0 - 3}' y='{y(t) + 3}' text-anchor='end'>{t:g}</text>")
        for t in _ticks(lo, hi, values):
            out.append(f"<text x='{x(t, k):.1f}' y='{mt + ph + 11}' text-anchor='middle'>{t:g}</text>")
        out.append(f"<text x='{x0 + pw / 2}' y='{mt + ph + 24}' text-anchor='middle'>"
                   f"{html.escape(axis)}</text>")
        for j, m in enumerate(matchers):
            pts, colour = series[region, m], _COLOURS[j % 6]
            if not pts:
                continue
            line = " ".join(f"{x(v, k):.1f},{y(mu):.1f}" for v, mu, _ in pts)
            out.append(f"<polyline points='{line}' fill='none' stroke='{colour}' "
                       f"stroke-width='{2 if j == 0 else 1.2}'/>")
            for v, mu, half in pts:
                cx = x(v, k)
                if not math.isnan(half):
                    a, b = y(max(0.0, mu - half)), y(min(ymax, mu + half))
                    out.append(f"<path d='M{cx:.1f},{a:.1f}V{b:.1f}M{cx - 2:.1f},{a:.1f}h4"
                               f"M{cx - 2:.1f},{b:.1f}h4' stroke='{colour}'/>")
                out.append(f"<circle cx='{cx:.1f}' cy='{y(mu):.1f}' r='2.2' fill='{colour}'/>")
    out.append(f"<text x='9' y='{mt + ph / 2}' transform='rotate(-90 9 {mt + ph / 2})' "
               "text-anchor='middle'>bad-2 (%)</text></svg>")
    return _svg_uri("".join(out))


def _error_maps(out_dir: Path, row: dict) -> str:
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from matcher.io import read_image, read_pfm

    plt = _pyplot()
    folder = out_dir / row["sample"]
    left = read_image(folder / "im0.png")
    gt = read_pfm(folder / "disp0GT.pfm").astype(np.float64)
    est = (read_pfm(out_dir / row["estimate"]).astype(np.float64) if row["estimate"]
           else np.full(gt.shape, np.inf))
    known, estimated = np.isfinite(gt), np.isfinite(est)
    hi = float(np.nanmax(np.where(known, gt, np.nan))) if known.any() else 1.0
    err = np.where(known & estimated, np.abs(np.where(estimated, est, 0) - np.where(known, gt, 0)),
                   np.nan)
    fig, axes = plt.subplots(1, 4, figsize=(12, 2.9), layout="constrained")
    turbo = plt.get_cmap("turbo").copy()
    axes[0].imshow(left, cmap="gray" if left.ndim == 2 else None)
    axes[0].set_title("left view", fontsize=8)

    def shown(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
        return np.ma.masked_array(np.where(mask, values, 0.0), ~mask)

    background = np.zeros((*gt.shape, 3))
    background[~known] = _NO_GT_RGB
    background[known & ~estimated] = _NO_ESTIMATE_RGB
    for ax, values, mask, title in ((axes[1], gt, known, "ground truth (px)"),
                                    (axes[2], est, estimated, "estimate (px)")):
        ax.imshow(background if ax is axes[2] else np.where(known[..., None], 0.0, _NO_GT_RGB))
        im = ax.imshow(shown(values, mask), cmap=turbo, vmin=0.0, vmax=hi)
        ax.set_title(title, fontsize=8)
    fig.colorbar(im, ax=axes[1:3], shrink=0.85, label="disparity (px)")
    emax = max(4.0, float(np.nanquantile(err, 0.99))) if np.isfinite(err).any() else 4.0
    axes[3].imshow(background)
    im = axes[3].imshow(np.ma.masked_invalid(err), cmap=ListedColormap(
        plt.get_cmap("viridis")(np.linspace(0, 1, 256))), vmin=0.0, vmax=emax)
    axes[3].set_title("|error| (px)", fontsize=8)
    fig.colorbar(im, ax=axes[3], shrink=0.85, label="|estimate - truth| (px)")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.legend(handles=[Patch(color=_NO_GT_RGB, label="no ground truth"),
                        Patch(color=_NO_ESTIMATE_RGB, label="no estimate")],
               loc="lower left", fontsize=7, ncol=2, frameon=False)
    return _figure_uri(fig)


# --------------------------------------------------------------------------- sections
def _pct(mean: float, half: float) -> str:
    if math.isnan(mean):
        return "–"
    return f"{mean:+.1f}" if math.isnan(half) else f"{mean:+.1f} ± {half:.1f}"


def _verdict(mean: float, half: float) -> str:
    if math.isnan(half):
        return "too few pairs"
    if mean - half > 0:
        return "worse"
    if mean + half < 0:
        return "better"
    return "no clear difference"


def _summary(rows: list[dict], matcher: str, references: Sequence[str]) -> list[str]:
    axes = sorted({r["axis"] for r in rows})
    out = ["<h2>Summary</h2>",
           f"<p>Paired difference of bad-2 ({html.escape(matcher)} minus reference, percentage "
           "points) over every (axis value, seed) both matchers were scored on; mean ± half width "
           "of the 95 % t-interval, t(0.975, n − 1) · s / √n. <b>worse</b>: the interval lies "
           "above 0; <b>better</b>: below 0. A sample the matcher failed on counts as 100 % bad "
           "there.</p>"]
    for ref in references:
        if not any(r["matcher"] == ref for r in rows):
            out.append(f"<p class='note'>No rows of the reference {html.escape(ref)} in results.csv.</p>")
            continue
        lines, verdicts = [], {"worse": [], "better": []}
        for axis in axes:
            for region in _REGIONS:
                diffs = paired_differences(rows, matcher, ref, axis=axis, region=region)
                if not diffs:
                    continue
                m, h, n = t_interval([100 * d for d in diffs])
                v = _verdict(m, h)
                if v in verdicts:
                    verdicts[v].append(f"{axis} / {region} ({_pct(m, h)})")
                lines.append(f"<tr class='{v.replace(' ', '-')}'><td>{html.escape(axis)}</td>"
                             f"<td>{region}</td><td>{n}</td><td>{_pct(m, h)}</td><td>{v}</td></tr>")
        out.append(f"<h3>against {html.escape(ref)}</h3><ul>"
                   f"<li>worse on: {html.escape(', '.join(verdicts['worse']) or 'nothing')}</li>"
                   f"<li>better on: {html.escape(', '.join(verdicts['better']) or 'nothing')}</li></ul>"
                   "<table><tr><th>axis</th><th>region</th><th>n pairs</th>"
                   "<th>bad-2 difference (points)</th><th>verdict</th></tr>"
                   + "".join(lines) + "</table>")
    return out


def _speed(rows: list[dict], matchers: Sequence[str]) -> list[str]:
    """Median seconds per pair and median Mpix x disparities / s of each matcher."""
    lines = []
    for m in matchers:
        per_pair = {(r["axis"], r["value"], r["seed"]): r for r in rows
                    if r["matcher"] == m and not r["error"]}
        secs = [r["seconds"] for r in per_pair.values() if r["seconds"] is not None]
        rate = [r["mpix_disp_per_s"] for r in per_pair.values() if r["mpix_disp_per_s"] is not None]
        if secs:
            lines.append(f"<tr><td>{html.escape(m)}</td><td>{len(per_pair)}</td>"
                         f"<td>{float(np.median(secs)):.3g}</td>"
                         f"<td>{float(np.median(rate)) if rate else math.nan:.3g}</td></tr>")
    if not lines:
        return []
    return ["<h3>Speed</h3><p>Over the pairs each matcher answered (wall time of one call, as the "
            "sweep measured it, on this run's machine and workers).</p><table><tr><th>matcher"
            "</th><th>pairs</th><th>median s / pair</th><th>median Mpix·disparities / s</th>"
            "</tr>", *lines, "</table>"]


def _properties(out_dir: Path, doc: dict) -> list[str]:
    props = doc.get("properties", [])
    failed = [p["name"] for p in props if p.get("required") and not p.get("passed")]
    out = ["<h2>Properties</h2>",
           f"<p>Suite <code>{html.escape(str(doc.get('suite')))}</code>: {len(props)} properties, "
           f"{len(failed)} required one(s) failed"
           + (f": {html.escape(', '.join(failed))}" if failed else "")
           + ". Robustness properties are reported, not required. Counterexamples (shrunk by "
           "hypothesis): left, right, expected and answer (disparity 0 … max, black = no "
           "estimate).</p>",
           "<table><tr><th>property</th><th>required</th><th>result</th><th>explanation</th></tr>"]
    for p in props:
        pics = []
        for rel in p.get("counterexample") or []:
            path = out_dir / rel
            if path.is_file():
                pics.append(f"<figure><img class='px' alt='{html.escape(rel)}' "
                            f"src='{_png_uri(path.read_bytes())}'><figcaption>"
                            f"{html.escape(Path(rel).stem)}</figcaption></figure>")
            else:
                pics.append(f"<span class='note'>missing: {html.escape(rel)}</span>")
        result = "passed" if p.get("passed") else "FAILED"
        out.append(f"<tr class='{'pass' if p.get('passed') else 'fail'}'>"
                   f"<td>{html.escape(str(p.get('name')))}</td>"
                   f"<td>{'yes' if p.get('required') else 'no (robustness)'}</td><td>{result}</td>"
                   f"<td>{html.escape(str(p.get('explanation')))}</td></tr>")
        if pics:
            out.append(f"<tr class='cx'><td colspan='4'>counterexample: {''.join(pics)}</td></tr>")
    return out + ["</table>"]


_STYLE = """
body { font-family: sans-serif; margin: 1.5em; max-width: 80em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: left; vertical-align: top; }
tr.worse td:last-child, tr.fail td:nth-child(3) { color: #b00; font-weight: bold; }
tr.pass td:nth-child(3) { color: #070; }
tr.better td:last-child { color: #070; }
.note { color: #a60; }
img { max-width: 100%; }
img.px { image-rendering: pixelated; width: 96px; }
tr.cx td { border-top: none; }
figure { display: inline-block; margin: 0 0.3em; text-align: center; font-size: 0.75em; }
"""


def write_report(out_dir: Path, *, matcher: str, references: Sequence[str]) -> Path:
    """Write ``out_dir/report.html`` (atomically) from ``results.csv`` and ``properties.json``.

    Parameters
    ----------
    out_dir : Path
        A validate folder.
    matcher : str
        The validated matcher's spec, as in the ``matcher`` column of ``results.csv``.
    references : sequence of str
        The reference matchers' specs.

    Returns
    -------
    Path
        The report.
    """
    out_dir = Path(out_dir)
    references = list(references)
    body = [f"<h1>Validation of <code>{html.escape(matcher)}</code></h1>",
            f"<p>References: {html.escape(', '.join(references) or 'none')}. Folder: "
            f"<code>{html.escape(str(out_dir))}</code>.</p>"]
    results = out_dir / "results.csv"
    rows = _read_results(results) if results.is_file() else None
    if rows is None:
        body.append(f"<p class='note'>No results.csv in {html.escape(str(out_dir))}: no sweep "
                    "results to summarise.</p>")
    elif not any(r["matcher"] == matcher for r in rows):
        body.append(f"<p class='note'>results.csv has no rows of {html.escape(matcher)}.</p>")
    else:
        failed = sorted({(r["axis"], r["value"], r["seed"], r["error"]) for r in rows
                         if r["matcher"] == matcher and r["error"]})
        if failed:
            body.append(f"<p class='note'>The matcher failed on {len(failed)} sample(s), e.g. "
                        f"{html.escape(failed[0][0])} = {failed[0][1]:g}, seed {failed[0][2]}: "
                        f"{html.escape(failed[0][3])}</p>")
        body += _summary(rows, matcher, references)
        body += _speed(rows, [matcher, *references])
        body.append("<h2>Axes</h2><p>bad-2 (% of the region's pixels with ground truth whose "
                    "error exceeds 2 px or that have no estimate) against each axis value; mean "
                    "over seeds, bars: 95 % t-interval.</p>")
        present = [m for m in [matcher, *references] if any(r["matcher"] == m for r in rows)]
        for axis in sorted({r["axis"] for r in rows}):
            body.append(f"<h3>{html.escape(axis)}</h3><img alt='bad-2 against {html.escape(axis)}' "
                        f"src='{_axis_plot(rows, axis, present)}'>")
        worst = sorted((r for r in rows if r["matcher"] == matcher and r["region"] == "all"
                        and r[HEADLINE] is not None),
                       key=lambda r: (-r[HEADLINE], r["axis"], r["value"], r["seed"]))
        body.append(f"<h2>Worst samples</h2><p>The {min(WORST_SAMPLES, len(worst))} samples with "
                    "the highest bad-2 over all pixels with ground truth.</p>")
        for r in worst[:WORST_SAMPLES]:
            body.append(f"<h3>{html.escape(r['axis'])} = {r['value']:g}, seed {r['seed']}: bad-2 "
                        f"{100 * r[HEADLINE]:.1f} %" + (f" ({html.escape(r['error'])})"
                                                          if r["error"] else "") + "</h3>")
            try:
                body.append(f"<img alt='error maps' src='{_error_maps(out_dir, r)}'>")
            except (OSError, ValueError) as exc:
                body.append(f"<p class='note'>cannot draw {html.escape(r['sample'])}: "
                            f"{html.escape(str(exc))}</p>")
    props = out_dir / "properties.json"
    if props.is_file():
        body += _properties(out_dir, json.loads(props.read_text(encoding="utf-8")))
    else:
        body.append(f"<h2>Properties</h2><p class='note'>No properties.json in "
                    f"{html.escape(str(out_dir))}: the property battery did not run.</p>")
    page = ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            f"<title>stereoforge validate: {html.escape(matcher)}</title>"
            f"<style>{_STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")
    path = out_dir / "report.html"
    atomic_write_bytes(path, page.encode("utf-8"))
    return path
