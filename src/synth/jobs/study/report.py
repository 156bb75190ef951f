"""``summary.md`` and the figures of a texture-versus-window study (:mod:`synth.jobs.study.run`)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from matcher.io import save_figure_atomic
from synth.jobs.study.config import StudyConfig

__all__ = ["summarize", "write_plots"]


# --------------------------------------------------------------------------- summary
def _interval(values: list[float]) -> tuple[float, float, int]:
    """``(mean, half width of the 95 % t-interval, n)``; half width NaN when n < 2."""
    v = np.asarray([x for x in values if x is not None], dtype=np.float64)
    n = v.size
    if n == 0:
        return math.nan, math.nan, 0
    if n < 2:
        return float(v.mean()), math.nan, 1
    from scipy.stats import t

    return float(v.mean()), float(t.ppf(0.975, n - 1) * v.std(ddof=1) / math.sqrt(n)), n


def _fmt(mean: float, half: float, digits: int = 1) -> str:
    if math.isnan(mean):
        return "–"
    if math.isnan(half):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {half:.{digits}f}"


def _level_label(cfg: StudyConfig, level: float) -> str:
    if cfg.axis in ("frequency", "edge_density"):
        return f"f={level:g}" if cfg.axis == "frequency" else f"ρ={level:g}"
    return f"{cfg.axis.partition('.')[2]}={level:g}"


def _table(header: list[str], body: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header),
            *["| " + " | ".join(r) + " |" for r in body], ""]


def _paired(rows: list[dict], a: str, b: str) -> dict[tuple, list[tuple[float, float, dict]]]:
    """``(kind, window, level, contrast) -> [(pobmp_a - pobmp_b, census_a / census_b, row_a)]``."""
    index = {(r["kind"], r["texture_level"], r["contrast"], r["seed"], r["method"], r["window"]): r
             for r in rows}
    out: dict[tuple, list[tuple[float, float, dict]]] = {}
    for key, ra in index.items():
        if key[4] != a:
            continue
        rb = index.get((*key[:4], b, key[5]))
        if rb is None:
            continue
        ratio = (ra["census_comparisons"] / rb["census_comparisons"]
                 if ra["census_comparisons"] and rb["census_comparisons"] else math.nan)
        out.setdefault((key[0], key[5], key[1], key[2]), []).append(
            (ra["pobmp"] - rb["pobmp"], ratio, ra))
    return out


#: Edge-density bins (fractions) of the summary's per-density table.
_RHO_BINS = (0.0, 0.02, 0.05, 0.10, 0.20, 0.30, 1.0)


def _density_table(cfg: StudyConfig, pairs: dict, a: str, b: str) -> list[str]:
    """Paired differences binned by measured edge density, kinds and levels pooled."""
    lines = [f"### {a.upper()} − {b.upper()} by measured edge density (all scenes, levels, "
             "contrasts)", "",
             "Each entry: PoBMP difference in points (95 % t-interval) / census comparisons of "
             f"{a.upper()} as % of {b.upper()}'s; n pairs in brackets.", ""]
    bins = list(zip(_RHO_BINS[:-1], _RHO_BINS[1:]))
    body = []
    for w in cfg.windows:
        entry = [str(w)]
        for lo, hi in bins:
            sel = [(d, r) for (kind, win, lv, c), v in pairs.items() if win == w
                   for d, r, row in v if lo <= row["edge_density"] < hi]
            if not sel:
                entry.append("–")
                continue
            m, h, n = _interval([d for d, _ in sel])
            entry.append(f"{_fmt(m, h, 2)} / {100 * float(np.mean([r for _, r in sel])):.1f} % "
                         f"({n})")
        body.append(entry)
    return lines + _table(["window", *[f"ρ {100 * lo:g}–{100 * hi:g} %" for lo, hi in bins]],
                          body)


def summarize(cfg: StudyConfig, rows: list[dict]) -> str:
    """``summary.md`` of a study from its result rows (the dicts behind ``results.csv``).

    Every entry is ``mean ± half width`` of the 95 % t-interval over the seeds of its group
    (one scene kind, texture level, contrast, method and window), except the tables by edge
    density, which pool every pair whose measured density falls in the bin.
    """
    levels, contrasts = cfg.levels, cfg.contrasts
    labels = [_level_label(cfg, lv) for lv in levels]
    what = {"frequency": "cycles per pixel at each object's centre depth",
            "edge_density": "target edge density"}.get(cfg.axis, f"dataset-config key {cfg.axis}")
    lines = [f"# Study `{cfg.name}`", "", cfg.description.strip(), "",
             f"- rig: {cfg.rig.width} x {cfg.rig.height}, fx = {cfg.rig.fx:g} px, baseline = "
             f"{cfg.rig.baseline:g} m; max_disparity = {cfg.max_disparity}, delta = {cfg.delta:g}",
             f"- scenes: {', '.join(cfg.kinds)}; seeds {', '.join(map(str, cfg.seeds))}; "
             f"texture `{cfg.texture}`, contrasts {', '.join(f'{c:g}' for c in contrasts)}, "
             f"noise sigma {cfg.noise_sigma:g} grey levels",
             f"- texture levels ({what}): {', '.join(f'{lv:g}' for lv in levels)}",
             f"- methods {', '.join(cfg.methods)}; windows {', '.join(map(str, cfg.windows))}",
             f"- {len(cfg.cells())} rendered pairs, {len(rows)} rows; each entry: mean ± half "
             f"width of the 95 % t-interval over the n = {len(cfg.seeds)} seeds "
             "(t(0.975, n − 1) s / sqrt(n))",
             "- PoBMP: % of non-occluded pixels with |error| > delta or no estimate",
             "- ρ: fraction of Canny edge pixels of the matched left image "
             "(matcher.edges.canny_edges defaults: sigma 1, thresholds 0.1 / 0.2)", ""]
    groups: dict[tuple, list[float]] = {}
    for r in rows:
        groups.setdefault((r["kind"], r["method"], r["window"], r["texture_level"], r["contrast"]),
                          []).append(r["pobmp"])
    first = [r for r in rows if r["method"] == cfg.methods[0] and r["window"] == cfg.windows[0]]
    lines += ["## Measured edge density ρ (%)", ""]
    body = []
    for kind in cfg.kinds:
        for c in contrasts:
            body.append([kind, f"{c:g}", *[_fmt(*_interval(
                [100 * r["edge_density"] for r in first if r["kind"] == kind
                 and r["contrast"] == c and r["texture_level"] == lv])[:2], 2) for lv in levels]])
    lines += _table(["scene", "contrast", *labels], body)
    if cfg.axis == "edge_density":
        lines += ["Frequencies found (cycles/px): " + ", ".join(
            f"{label}: {_fmt(*_interval([r['frequency_px'] for r in first if r['texture_level'] == lv])[:2], 4)}"
            for lv, label in zip(levels, labels)), ""]
    for kind in cfg.kinds:
        for c in contrasts:
            lines += [f"## PoBMP (%), {kind}, contrast {c:g}", ""]
            body = [[f"{m} {w}", *[_fmt(*_interval(groups.get((kind, m, w, lv, c), []))[:2])
                                   for lv in levels]] for m in cfg.methods for w in cfg.windows]
            lines += _table(["method window", *labels], body)
    for a, b in (("awct", "ct"), ("awsct", "sct"), ("cthw", "ct")):
        if a not in cfg.methods or b not in cfg.methods:
            continue
        pairs = _paired(rows, a, b)
        lines += [f"## {a.upper()} − {b.upper()} (paired: same pair, same window)", "",
                  f"Each entry: PoBMP difference in points / census comparisons of {a.upper()} "
                  f"as % of {b.upper()}'s at the same window.", ""]
        for kind in cfg.kinds:
            for c in contrasts:
                lines += [f"### {kind}, contrast {c:g}", ""]
                body = []
                for w in cfg.windows:
                    entry = [str(w)]
                    for lv in levels:
                        p = pairs.get((kind, w, lv, c), [])
                        entry.append(f"{_fmt(*_interval([x for x, _, _ in p])[:2], 2)} / "
                                     f"{_interval([100 * y for _, y, _ in p])[0]:.1f} %")
                    body.append(entry)
                lines += _table(["window", *labels], body)
        lines += _density_table(cfg, pairs, a, b)
    return "\n".join(lines).rstrip() + "\n"


# --------------------------------------------------------------------------- plots
def write_plots(cfg: StudyConfig, rows: list[dict], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [f"{lv:g}" for lv in cfg.levels]
    xlabel = {"frequency": "texture frequency (cycles/px)",
              "edge_density": "edge density target"}.get(cfg.axis, cfg.axis)
    mean: dict[tuple, float] = {}
    groups: dict[tuple, list[float]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["window"], r["texture_level"], r["contrast"]),
                          []).append(r["pobmp"])
    for k, v in groups.items():
        mean[k] = float(np.mean(v))
    vmax = max(mean.values()) if mean else 100.0
    nr, nc = len(cfg.contrasts), len(cfg.methods)
    fig, axes = plt.subplots(nr, nc, figsize=(2.6 * nc + 1, 2.4 * nr + 0.6), squeeze=False,
                             sharex=True, sharey=True, layout="constrained")
    im = None
    for i, c in enumerate(cfg.contrasts):
        for j, m in enumerate(cfg.methods):
            grid = np.array([[mean.get((m, w, lv, c), np.nan) for lv in cfg.levels]
                             for w in cfg.windows])
            ax = axes[i, j]
            im = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis_r", vmin=0,
                           vmax=vmax)
            for (yy, xx), v in np.ndenumerate(grid):
                if np.isfinite(v):
                    ax.text(xx, yy, f"{v:.0f}", ha="center", va="center", fontsize=6,
                            color="white" if v > 0.6 * vmax else "black")
            ax.set_title(f"{m.upper()}, contrast {c:g}", fontsize=8)
            ax.set_xticks(range(len(labels)), labels, fontsize=6, rotation=45)
            ax.set_yticks(range(len(cfg.windows)), [str(w) for w in cfg.windows], fontsize=6)
            if i == nr - 1:
                ax.set_xlabel(xlabel, fontsize=7)
            if j == 0:
                ax.set_ylabel("window", fontsize=7)
    fig.colorbar(im, ax=axes, shrink=0.8, label="PoBMP (%, non-occluded)")
    save_figure_atomic(fig, out / "pobmp_heatmap.png", dpi=110)
    plt.close(fig)

    n = len(cfg.levels)
    cols = min(n, 3)
    fig, axes = plt.subplots(math.ceil(n / cols), cols, figsize=(4.2 * cols, 3.3 * math.ceil(n / cols)),
                             squeeze=False, sharey=True)
    for k, lv in enumerate(cfg.levels):
        ax = axes[k // cols, k % cols]
        for m in cfg.methods:
            sel = [r for r in rows if r["method"] == m and r["texture_level"] == lv]
            pts = []
            for w in cfg.windows:
                ws = [r for r in sel if r["window"] == w]
                if ws:
                    ops = [r["census_per_pixel"] for r in ws]
                    pts.append((None if ops[0] is None else float(np.mean(ops)),
                                float(np.mean([r["pobmp"] for r in ws]))))
            if pts and pts[0][0] is None:
                best = min(p[1] for p in pts)
                ax.axhline(best, ls="--", lw=1, color="grey", label=f"{m.upper()} (best window)")
                continue
            adaptive = m.startswith("aw")
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "x--" if adaptive else "o-",
                    ms=5 if adaptive else 3, lw=1, label=m.upper())
        ax.set_xscale("log")
        ax.set_title(_level_label(cfg, lv), fontsize=9)
        ax.set_xlabel("census comparisons per pixel (both views)", fontsize=7)
        ax.set_ylabel("PoBMP (%, non-occluded)", fontsize=7)
        ax.tick_params(labelsize=6)
    for k in range(n, axes.size):
        axes.flat[k].axis("off")
    axes[0, 0].legend(fontsize=6)
    fig.suptitle(f"operations against accuracy (windows {cfg.windows[0]}..{cfg.windows[-1]}; "
                 "mean over scenes, contrasts, seeds)", fontsize=9)
    fig.tight_layout()
    save_figure_atomic(fig, out / "ops_accuracy.png", dpi=110)
    plt.close(fig)
