"""``report.html`` of a validate run: one self-contained page (every image a ``data:`` URI).

:func:`write_report` reads ``results.csv`` and ``properties.json`` of a validate folder (either may
be missing; the page says so) and writes, in order:

1. **Summary**, per comparison (the baseline, if any, then each reference): one heatmap of axis
   x region (:func:`synth.validate.figures.heatmap`: colour = the paired difference of bad-2 in
   points, matcher minus the other, a frame where the 95 % t-interval excludes 0, the number in
   each cell, a colour bar), one sentence with the three axes where the matcher is most clearly
   worse and one with the three where it is most clearly better, then every axis x region with
   its interval folded in a ``<details>`` (:mod:`synth.validate.differences`). A sample the
   matcher failed on scores bad-2 = 100 % there (no estimate anywhere), as in ``results.csv``.
   Below, each matcher's median seconds per pair and Mpix·disparities per second.
2. **Real scenes** (``--real``): bad-2 per scene, matcher and region.
3. **One plot per axis**: bad-2 against the axis value for the matcher and the references, one
   panel per region, mean over seeds with the 95 % t-interval as error bars.
4. **Worst samples** of the matcher, one per axis (highest bad-2 over ``all``): left view,
   ground truth, estimate (one colour bar, pixels) and ``|error|`` (its own colour bar).
5. **Properties** of the battery (:mod:`synth.validate.properties`) with the counterexamples.
"""

from __future__ import annotations

import html
import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from matcher.io import atomic_write_bytes
from synth.validate.differences import (HEADLINE, difference_table, paired_differences,
                                        read_results, t_interval)
from synth.validate.figures import REGIONS, axis_plot, error_maps, heatmap, png_uri

__all__ = ["HEADLINE", "WORST_SAMPLES", "write_report", "paired_differences", "t_interval"]

#: How many of the matcher's worst samples get error maps (each from another axis).
WORST_SAMPLES = 4
_REAL = "real"


# --------------------------------------------------------------------------- sections
def _pct(mean: float, half: float) -> str:
    if math.isnan(mean):
        return "–"
    return f"{mean:+.1f}" if math.isnan(half) else f"{mean:+.1f} ± {half:.1f}"


def _extremes(table: list[dict], verdict: str) -> list[dict]:
    """Per axis (``real`` pooled) its clearest cell of ``verdict``, the 3 largest ``|mean|``."""
    best: dict[str, dict] = {}
    for r in table:
        if r["verdict"] == verdict and not r["scene"] and (
                r["axis"] not in best or abs(r["mean"]) > abs(best[r["axis"]]["mean"])):
            best[r["axis"]] = r
    return sorted(best.values(), key=lambda r: -abs(r["mean"]))[:3]


def _sentence(table: list[dict], verdict: str, other: str) -> str:
    found = _extremes(table, verdict)
    who = html.escape(other)
    if not found:
        return f"<p class='{verdict}'>Clearly {verdict} than {who} on no axis.</p>"
    parts = [f"<b>{html.escape('real scenes' if r['axis'] == _REAL else r['axis'])}</b> "
             f"({_pct(r['mean'], r['half_width'])} points, {r['region']})" for r in found]
    listed = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    return f"<p class='{verdict}'>Most {verdict} than {who}: {listed}.</p>"


def _comparison(table: list[dict], other: str, note: str = "") -> list[str]:
    mine = [r for r in table if r["reference"] == other]
    lines = [f"<tr class='{r['verdict'].replace(' ', '-')}'><td>{html.escape(r['axis'])}</td>"
             f"<td>{html.escape(r['scene'])}</td><td>{r['region']}</td><td>{r['n']}</td>"
             f"<td>{_pct(r['mean'], r['half_width'])}</td><td>{r['verdict']}</td></tr>"
             for r in mine]
    return [f"<h3>against {html.escape(other)}</h3>{note}",
            f"<img class='heatmap' alt='paired differences against {html.escape(other)}' "
            f"src='{heatmap(table, other)}'>",
            "<p class='legend'>Colour: bad-2 of the matcher minus that of "
            f"{html.escape(other)}, in percentage points (red: worse, blue: better). Framed, "
            "bold: the 95 % interval excludes 0. Grey: no pixel of that region. A single real "
            "scene is one pair: its difference, without an interval.</p>",
            _sentence(mine, "worse", other), _sentence(mine, "better", other),
            f"<details><summary>All {len(mine)} axis x region differences against "
            f"{html.escape(other)}: mean ± half width, pairs, verdict</summary>"
            "<table><tr><th>axis</th><th>scene</th><th>region</th><th>n pairs</th>"
            "<th>bad-2 difference (points)</th><th>verdict</th></tr>" + "".join(lines)
            + "</table></details>"]


def _summary(rows: list[dict], matcher: str, others: Sequence[str],
             baseline: tuple[str, Path] | None) -> list[str]:
    out = ["<h2>Summary</h2>",
           f"<p>Paired difference of bad-2 ({html.escape(matcher)} minus the other matcher, "
           "percentage points) over every sample both were scored on (axis value and seed, or "
           "real scene); mean ± half width of the 95 % t-interval, t(0.975, n − 1) · s / √n. "
           "<b>worse</b>: the interval lies above 0; <b>better</b>: below 0. A sample the "
           "matcher failed on counts as 100 % bad there.</p>"]
    table = difference_table(rows, matcher, [o for o in others
                                            if any(r["matcher"] == o for r in rows)])
    for other in others:
        if not any(r["matcher"] == other for r in rows):
            out.append(f"<p class='note'>No rows of the reference {html.escape(other)} in "
                       "results.csv.</p>")
            continue
        note = ""
        if baseline is not None and other == baseline[0]:
            scenes = list(dict.fromkeys(r["scene"] for r in rows
                                        if r["axis"] == _REAL and r["matcher"] == other))
            real = (f" Real scenes compared: {html.escape(', '.join(scenes))}." if scenes
                    else " No real scene.")
            note = (f"<p>The baseline: the matcher of the finished run "
                    f"<code>{html.escape(str(baseline[1]))}</code>, on the same pairs.{real}</p>")
        out += _comparison(table, other, note)
    return out


def _speed(rows: list[dict], matchers: Sequence[str]) -> list[str]:
    """Median seconds per pair and median Mpix x disparities / s of each matcher."""
    lines = []
    for m in matchers:
        per_pair = {(r["axis"], r["value"], r["seed"], r.get("scene", "")): r for r in rows
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


def _real(rows: list[dict], matchers: Sequence[str]) -> list[str]:
    """bad-2 of each real scene per matcher and region."""
    real = [r for r in rows if r["axis"] == _REAL]
    if not real:
        return []
    by = {(r["scene"], r["matcher"], r["region"]): r[HEADLINE] for r in real}
    lines = []
    for scene in dict.fromkeys(r["scene"] for r in real):
        for m in matchers:
            if any((scene, m, g) in by for g in REGIONS):
                cells = "".join("<td>–</td>" if by.get((scene, m, g)) is None
                                else f"<td>{100 * by[scene, m, g]:.1f}</td>" for g in REGIONS)
                lines.append(f"<tr><td>{html.escape(scene)}</td><td>{html.escape(m)}</td>"
                             f"{cells}</tr>")
    return ["<h2>Real scenes</h2><p>bad-2 (%) of each real scene, scored like the rendered "
            "pairs (regions from the scene's own ground truth and mask, or a left-right check "
            "of its ground truths).</p><table><tr><th>scene</th><th>matcher</th>"
            + "".join(f"<th>{g}</th>" for g in REGIONS) + "</tr>", *lines, "</table>"]


def _worst(rows: list[dict], matcher: str) -> list[dict]:
    """The matcher's worst sample (bad-2 over ``all``) of each axis, the worst axes first."""
    worst: dict[str, dict] = {}
    for r in rows:
        if r["matcher"] == matcher and r["region"] == "all" and r[HEADLINE] is not None:
            key = (-r[HEADLINE], str(r["value"]), str(r["seed"]), r.get("scene", ""))
            if r["axis"] not in worst or key < worst[r["axis"]][0]:
                worst[r["axis"]] = (key, r)
    return [r for _, r in sorted(worst.values(), key=lambda kr: (kr[0], kr[1]["axis"]))]


def _worst_section(rows: list[dict], matcher: str, source: Path) -> list[str]:
    worst = _worst(rows, matcher)[:WORST_SAMPLES]
    body = [f"<h2>Worst samples</h2><p>The {len(worst)} samples with the highest bad-2 over "
            "all pixels with ground truth, one per axis.</p>"]
    for r in worst:
        where = (html.escape(r["scene"]) if r["axis"] == _REAL else
                 f"{html.escape(r['axis'])} = {r['value']:g}, seed {r['seed']}"
                 + (f" ({html.escape(r['scene'])})" if r.get("scene") else ""))
        body.append(f"<h3>{where}: bad-2 {100 * r[HEADLINE]:.1f} %"
                    + (f" ({html.escape(r['error'])})" if r["error"] else "") + "</h3>")
        try:
            body.append(f"<img alt='error maps' src='{error_maps(source, r)}'>")
        except (OSError, ValueError) as exc:
            body.append(f"<p class='note'>cannot draw {html.escape(r['sample'])}: "
                        f"{html.escape(str(exc))}</p>")
    return body


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
                            f"src='{png_uri(path.read_bytes())}'><figcaption>"
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
code { overflow-wrap: anywhere; }
tr.worse td:last-child, tr.fail td:nth-child(3) { color: #b00; font-weight: bold; }
tr.pass td:nth-child(3) { color: #070; }
tr.better td:last-child { color: #070; }
p.worse b { color: #b2182b; } p.better b { color: #2166ac; }
p.legend { font-size: 0.8em; color: #555; margin-top: 0; }
details { margin-bottom: 1.5em; } summary { cursor: pointer; color: #333; }
.note { color: #a60; }
img { max-width: 100%; }
img.px { image-rendering: pixelated; width: 96px; }
tr.cx td { border-top: none; }
figure { display: inline-block; margin: 0 0.3em; text-align: center; font-size: 0.75em; }
"""


def write_report(out_dir: Path, *, matcher: str, references: Sequence[str],
                 rows: list[dict] | None = None, source: Path | None = None,
                 baseline: tuple[str, Path] | None = None) -> Path:
    """Write ``out_dir/report.html`` (atomically) from ``results.csv`` and ``properties.json``.

    Parameters
    ----------
    out_dir : Path
        Where the page goes (a validate folder, or the ``--compare`` output).
    matcher : str
        The validated matcher's spec, as in the ``matcher`` column of ``results.csv``.
    references : sequence of str
        The reference matchers' specs.
    rows : list of dict, optional
        The results rows (:func:`synth.validate.differences.read_results`); default: those of
        ``source/results.csv``. With a baseline they hold its matcher's rows too, under its label.
    source : Path, optional
        The validate folder whose pairs, estimates and ``properties.json`` are shown (default
        ``out_dir``).
    baseline : (str, Path), optional
        The label of the baseline's rows and its folder: compared first.

    Returns
    -------
    Path
        The report.
    """
    out_dir = Path(out_dir)
    source = out_dir if source is None else Path(source)
    references = list(references)
    others = ([baseline[0]] if baseline else []) + references
    body = [f"<h1>Validation of <code>{html.escape(matcher)}</code></h1>",
            f"<p>References: {html.escape(', '.join(references) or 'none')}"
            + (f"; baseline: <code>{html.escape(str(baseline[1]))}</code>" if baseline else "")
            + f". Folder: <code>{html.escape(str(source))}</code>.</p>"]
    results = source / "results.csv"
    if rows is None and results.is_file():
        rows = read_results(results)
    if rows is None:
        body.append(f"<p class='note'>No results.csv in {html.escape(str(source))}: no sweep "
                    "results to summarise.</p>")
    elif not any(r["matcher"] == matcher for r in rows):
        body.append(f"<p class='note'>results.csv has no rows of {html.escape(matcher)}.</p>")
    else:
        failed = sorted({(r["axis"], str(r["value"]), str(r["seed"]), r.get("scene", ""),
                          r["error"]) for r in rows if r["matcher"] == matcher and r["error"]})
        if failed:
            axis, value, seed, scene, error = failed[0]
            at = scene if axis == _REAL else f"{axis} = {value}, seed {seed}"
            body.append(f"<p class='note'>The matcher failed on {len(failed)} sample(s), e.g. "
                        f"{html.escape(at)}: {html.escape(error)}</p>")
        body += _summary(rows, matcher, others, baseline)
        body += _speed(rows, [matcher, *others])
        present = [m for m in [matcher, *others] if any(r["matcher"] == m for r in rows)]
        body += _real(rows, present)
        body.append("<h2>Axes</h2><p>bad-2 (% of the region's pixels with ground truth whose "
                    "error exceeds 2 px or that have no estimate) against each axis value; mean "
                    "over seeds, bars: 95 % t-interval.</p>")
        for axis in dict.fromkeys(r["axis"] for r in rows if r["axis"] != _REAL):
            body.append(f"<h3>{html.escape(axis)}</h3><img alt='bad-2 against {html.escape(axis)}' "
                        f"src='{axis_plot(rows, axis, present)}'>")
        body += _worst_section(rows, matcher, source)
    props = source / "properties.json"
    if props.is_file():
        body += _properties(source, json.loads(props.read_text(encoding="utf-8")))
    else:
        body.append(f"<h2>Properties</h2><p class='note'>No properties.json in "
                    f"{html.escape(str(source))}: the property battery did not run.</p>")
    page = ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            "<meta name='viewport' content='width=device-width, initial-scale=1'>"
            f"<title>stereoforge validate: {html.escape(matcher)}</title>"
            f"<style>{_STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")
    path = out_dir / "report.html"
    atomic_write_bytes(path, page.encode("utf-8"))
    return path
