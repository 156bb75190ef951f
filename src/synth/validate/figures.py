"""The figures of ``report.html``, each a ``data:`` URI: axis plots and the summary heatmap
(SVG drawn here: matplotlib took seconds per figure, too slow for a quick run's dozen axes),
and the error maps of a sample (matplotlib).
"""

from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path

import numpy as np

from synth.validate.differences import HEADLINE, t_interval

__all__ = ["REGIONS", "png_uri", "svg_uri", "axis_plot", "error_maps", "heatmap"]

REGIONS = ("all", "nonocc", "occluded", "textureless", "discontinuity")
_REGIONS = REGIONS
_NO_GT_RGB = (0.78, 0.78, 0.78)
_NO_ESTIMATE_RGB = (1.0, 0.0, 1.0)
#: Diverging palette of the heatmap, from -1 (better: blue) through 0 (white) to +1 (worse: red)
#: (ColorBrewer RdBu, reversed).
_DIVERGING = ((-1.0, (33, 102, 172)), (-0.5, (146, 197, 222)), (0.0, (247, 247, 247)),
              (0.5, (244, 165, 130)), (1.0, (178, 24, 43)))


def png_uri(data: bytes) -> str:
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def _figure_uri(fig) -> str:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80, metadata={"Software": None})
    plt.close(fig)
    return png_uri(buf.getvalue())


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")


def svg_uri(svg: str) -> str:
    return "data:image/svg+xml;base64," + base64.b64encode(svg.encode("utf-8")).decode("ascii")


def _ticks(lo: float, hi: float, values: list[float]) -> list[float]:
    if len(values) <= 7:
        return values
    return [lo + (hi - lo) * k / 4 for k in range(5)]


def axis_plot(rows: list[dict], axis: str, matchers: list[str]) -> str:
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
    return svg_uri("".join(out))


def error_maps(out_dir: Path, row: dict) -> str:
    """Left view, ground truth, estimate and |error| of a results row's sample (a PNG URI)."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from matcher.io import read_pfm
    from synth.validate.pairs import read_pair_folder

    plt = _pyplot()
    left, _, gt, _ = read_pair_folder(out_dir / row["sample"])
    gt = gt.astype(np.float64)
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


def _diverging(t: float) -> tuple[int, int, int]:
    t = max(-1.0, min(1.0, t))
    for (a, ca), (b, cb) in zip(_DIVERGING, _DIVERGING[1:]):
        if t <= b:
            f = (t - a) / (b - a)
            return tuple(round(x + f * (y - x)) for x, y in zip(ca, cb))  # type: ignore
    return _DIVERGING[-1][1]


def _nice(value: float) -> float:
    """The smallest of 1, 2, 5 x 10^k at or above ``value`` (at least 1)."""
    value = max(float(value), 1.0)
    k = 10 ** math.floor(math.log10(value))
    return next(m * k for m in (1, 2, 5, 10) if m * k >= value - 1e-9)


def heatmap(table: list[dict], reference: str) -> str:
    """Axis x region heatmap of the paired differences against ``reference`` (an SVG URI).

    Rows: the axes, then ``real`` (the real scenes pooled) and each real scene; columns: the
    regions. A cell's colour is the mean difference in bad-2 points (red = worse, blue =
    better, the scale symmetric and clipped at the colour bar's ends: the 90th percentile of
    ``|mean|`` rounded up to 1, 2 or 5 x 10^k), its number the mean; a dark frame and bold type
    where the 95 % interval excludes 0; grey where the region has no pixel.
    """
    cells = {(r["axis"], r["scene"], r["region"]): r for r in table if r["reference"] == reference}
    groups = list(dict.fromkeys((r["axis"], r["scene"]) for r in table
                                if r["reference"] == reference))
    means = [abs(r["mean"]) for r in cells.values() if not math.isnan(r["mean"])]
    scale = _nice(float(np.quantile(means, 0.9)) if means else 1.0)
    labels = [scene or (f"real ({sum(1 for g in groups if g[1])} scenes)" if axis == "real"
                        else axis) for axis, scene in groups]
    cw, ch, top = 88, 21, 32
    lw = round(14 + 6.6 * max([len(lab) for lab in labels] + [8]))
    bar_x = lw + cw * len(_REGIONS) + 18
    height = top + ch * len(groups) + 12
    width = bar_x + 124
    out = [f"<svg xmlns='http://www.w3.org/2000/svg' width='{width}' height='{height}' "
           "font-family='sans-serif' font-size='12'><rect width='100%' height='100%' "
           "fill='white'/>"]
    for k, region in enumerate(_REGIONS):
        out.append(f"<text x='{lw + k * cw + cw / 2}' y='{top - 9}' text-anchor='middle' "
                   f"font-weight='bold' font-size='11'>{region}</text>")
    for j, ((axis, scene), label) in enumerate(zip(groups, labels)):
        y = top + j * ch
        if scene and not groups[j - 1][1]:  # the first real scene: a separator above
            out.append(f"<line x1='4' x2='{lw + cw * len(_REGIONS)}' y1='{y}' y2='{y}' "
                       "stroke='#444'/>")
        out.append(f"<text x='{lw - 6}' y='{y + ch / 2 + 4}' text-anchor='end'>"
                   f"{html.escape(label)}</text>")
        for k, region in enumerate(_REGIONS):
            x, r = lw + k * cw, cells.get((axis, scene, region))
            if r is None:
                out.append(f"<rect x='{x}' y='{y}' width='{cw}' height='{ch}' fill='#ddd' "
                           "stroke='white'/>")
                continue
            rgb = _diverging(r["mean"] / scale)
            clear = r["verdict"] in ("worse", "better")
            out.append(f"<rect x='{x}' y='{y}' width='{cw}' height='{ch}' "
                       f"fill='rgb{rgb}' stroke='white'/>")
            if clear:
                out.append(f"<rect x='{x + 1.5}' y='{y + 1.5}' width='{cw - 3}' "
                           f"height='{ch - 3}' fill='none' stroke='#111' stroke-width='2'/>")
            ink = "white" if abs(r["mean"]) > 0.6 * scale else "#111"
            weight = " font-weight='bold'" if clear else ""
            out.append(f"<text x='{x + cw / 2}' y='{y + ch / 2 + 4}' text-anchor='middle' "
                       f"fill='{ink}'{weight}>{r['mean']:+.1f}</text>")
    span = ch * len(groups)
    steps = 40
    for i in range(steps):  # colour bar: +scale at the top
        t = 1 - 2 * (i + 0.5) / steps
        out.append(f"<rect x='{bar_x}' y='{top + i * span / steps:.2f}' width='14' "
                   f"height='{span / steps + 0.5:.2f}' fill='rgb{_diverging(t)}'/>")
    for t in (1.0, 0.5, 0.0, -0.5, -1.0):
        y = top + (1 - t) / 2 * span
        edge = "≥ " if t == 1.0 else "≤ " if t == -1.0 else ""
        out.append(f"<line x1='{bar_x + 14}' x2='{bar_x + 18}' y1='{y}' y2='{y}' stroke='#111'/>"
                   f"<text x='{bar_x + 21}' y='{y + 4}'>{edge}{t * scale:+g}</text>")
    cx = bar_x + 84
    out.append(f"<text x='{cx}' y='{top + span / 2}' transform='rotate(-90 {cx} {top + span / 2})' "
               "text-anchor='middle'>bad-2 difference (points)</text></svg>")
    return svg_uri("".join(out))
