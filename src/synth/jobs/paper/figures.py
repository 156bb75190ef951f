"""Figures of the ``paper`` report beside the paper's own numbers, and colour-mapped results.

- :func:`table1_with_paper`: Table 1's rows with the paper's PoBMP and our difference;
- :func:`fig_pobmp_window`: PoBMP of CT and CTHW against the window, the paper's values overlaid;
- :func:`fig_colour_maps`: ground truth and both methods' disparities in one colour map with a
  colour bar, their absolute errors with another, and a legend for the pixels without ground
  truth (and those without an estimate).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

__all__ = ["ERROR_SCALE", "PAPER_COLUMNS", "fig_colour_maps", "fig_pobmp_window", "table1_with_paper"]

#: Columns added to ``table1.csv``: the paper's PoBMP (%) and ours minus the paper's (points);
#: empty where the paper has no value (its windows are 3..13, its six scenes only).
PAPER_COLUMNS = ("paper_pobmp", "pobmp_minus_paper")
#: Absolute errors (px) at the top of the error maps' colour bar (4 x the PoBMP threshold).
ERROR_SCALE = 12.0
_METHODS = ("ct", "cthw")
_UNKNOWN = "#7f7f7f"  # grey: no ground truth
_NO_ESTIMATE = "#000000"  # black: the matcher gave no disparity (inf / NaN)


def _paper_value(paper: Mapping[str, Mapping[int, tuple[float, float]]], row: dict) -> float | None:
    values = paper.get(row["scene"], {}).get(row["window"])
    return None if values is None else values[_METHODS.index(row["method"])]


def table1_with_paper(rows: list[dict], paper: Mapping[str, Mapping[int, tuple[float, float]]]
                      ) -> list[dict]:
    """``rows`` of Table 1 with :data:`PAPER_COLUMNS` (``""`` where the paper has no value).

    Examples
    --------
    >>> table1_with_paper([{"scene": "S", "window": 3, "method": "cthw", "pobmp": 40.0}],
    ...                   {"S": {3: (80.0, 41.5)}})[0]["pobmp_minus_paper"]
    -1.5
    """
    out = []
    for row in rows:
        ref = _paper_value(paper, row)
        out.append({**row, "paper_pobmp": "" if ref is None else ref,
                    "pobmp_minus_paper": "" if ref is None else round(row["pobmp"] - ref, 6)})
    return out


def fig_pobmp_window(scene: str, rows: list[dict],
                     paper: Mapping[str, Mapping[int, tuple[float, float]]],
                     save: Callable[[Figure, Path], None], path: Path) -> None:
    """PoBMP (%) against the window side: ours as lines, the paper's as open markers."""
    fig = Figure(figsize=(5, 3.5))
    ax = fig.subplots()
    for method, colour in zip(_METHODS, ("tab:blue", "tab:orange"), strict=True):
        ours = sorted((r["window"], r["pobmp"]) for r in rows if r["method"] == method)
        ax.plot(*zip(*ours, strict=True), "o-", color=colour, label=f"{method.upper()} (ours)")
        theirs = sorted((w, v[_METHODS.index(method)]) for w, v in paper.get(scene, {}).items())
        if theirs:
            ax.plot(*zip(*theirs, strict=True), "s--", color=colour, mfc="none",
                    label=f"{method.upper()} (paper, Table 1)")
    ax.set_xlabel("window side")
    ax.set_ylabel("PoBMP (%), error > 3 px")
    ax.set_title(f"{scene}: PoBMP against the window", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    save(fig, path)


def fig_colour_maps(scene: str, gt: np.ndarray, maps: Mapping[str, np.ndarray], d_max: float,
                    save: Callable[[Figure, Path], None], path: Path) -> None:
    """Disparities (GT and ``maps``) with one colour bar, absolute errors with another.

    Pixels without ground truth are grey in every panel, pixels without an estimate black;
    a legend names both. Errors of :data:`ERROR_SCALE` px and more share the top colour.
    """
    import matplotlib

    known = np.isfinite(gt) & (gt > 0)
    n = 1 + len(maps)
    fig = Figure(figsize=(3.2 * n, 5.6))
    axes = fig.subplots(2, n, squeeze=False)
    disp_cmap = matplotlib.colormaps["viridis"].with_extremes(bad=_UNKNOWN)
    err_cmap = matplotlib.colormaps["YlOrRd"].with_extremes(bad=_UNKNOWN)
    panels = {"ground truth": np.where(known, gt, np.nan)}
    for name, d in maps.items():
        panels[name] = np.where(known, d, np.nan)
    black = matplotlib.colors.ListedColormap([_NO_ESTIMATE])

    def no_estimate(ax, d: np.ndarray) -> None:
        missing = known & ~np.isfinite(d)
        if missing.any():
            ax.imshow(np.ma.masked_where(~missing, missing), cmap=black, interpolation="nearest")

    image = None
    for ax, (name, d) in zip(axes[0], panels.items(), strict=True):
        image = ax.imshow(d, cmap=disp_cmap, vmin=0, vmax=d_max, interpolation="nearest")
        no_estimate(ax, d)
        ax.set_title(f"{scene}: {name}" if name == "ground truth" else name, fontsize=8)
        ax.set_axis_off()
    fig.colorbar(image, ax=list(axes[0]), shrink=0.8, label="disparity (px)")
    axes[1][0].set_axis_off()
    err_image = None
    for ax, (name, d) in zip(axes[1][1:], maps.items(), strict=True):
        err = np.where(known & np.isfinite(d), np.abs(d - gt), np.nan)
        err_image = ax.imshow(err, cmap=err_cmap, vmin=0, vmax=ERROR_SCALE, interpolation="nearest")
        no_estimate(ax, d)
        ax.set_title(f"|{name} - GT|", fontsize=8)
        ax.set_axis_off()
    if err_image is not None:
        fig.colorbar(err_image, ax=list(axes[1]), shrink=0.8, label="absolute error (px)")
    axes[1][0].legend(handles=[Patch(color=_UNKNOWN, label="unknown ground truth"),
                               Patch(color=_NO_ESTIMATE, label="no estimate")],
                      loc="center", fontsize=8, frameon=False)
    save(fig, path)
