"""report.html of a validate folder: content, missing inputs, and no broken image in Chromium.

The validate folder is made here (``make_validate_dir``): warped planar pairs from
``matcher.testing`` on two axes (sensor noise, and the pair's disparity scale), scored for real
with CT-9, OpenCV BM and a deliberately poor matcher, written with ``matcher.io`` in the layout
of ``docs/validate.md`` (the sweep of ``synth.validate.run`` writes the same columns).
"""

from __future__ import annotations

import csv
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from matcher import match
from matcher.io import atomic_write_bytes, encode_png, write_pfm
from synth.validate.properties import run_battery
from synth.validate.report import paired_differences, t_interval, write_report

COLUMNS = ("matcher", "axis", "value", "seed", "scene", "region", "bad_0_5", "bad_1", "bad_2",
           "bad_4", "avgerr", "rms", "a50", "a90", "a99", "coverage", "seconds", "mpix_disp_per_s",
           "error", "sample", "estimate")
REGIONS = ("all", "nonocc", "occluded", "textureless", "discontinuity")


def _ct9(left, right, *, max_disparity):
    return match(left, right, method="ct", window=9, max_disparity=max_disparity).disparity


def _bm(left, right, *, max_disparity):
    return match(left, right, method="bm", window=9, max_disparity=max_disparity).disparity


def _poor(left, right, *, max_disparity):
    """A 3 x 3 census: noisy on purpose, so the report has something to show."""
    return match(left, right, method="ct", window=3, max_disparity=max_disparity).disparity


def _scores(est: np.ndarray | None, gt: np.ndarray, region: np.ndarray) -> dict:
    n = int(region.sum())
    if n == 0:
        return {}
    e = np.full(n, np.inf) if est is None else est[region].astype(np.float64)
    ok = np.isfinite(e)
    err = np.abs(e[ok] - gt[region][ok])
    out = {f"bad_{str(t).replace('.', '_')}": float(1 - np.count_nonzero(err <= t) / n)
           for t in (0.5, 1, 2, 4)}
    out["coverage"] = float(ok.mean())
    if err.size:
        out.update(avgerr=float(err.mean()), rms=float(np.sqrt(np.mean(err**2))),
                   a50=float(np.quantile(err, 0.5)), a90=float(np.quantile(err, 0.9)),
                   a99=float(np.quantile(err, 0.99)))
    return out


def _samples(seeds, real: int):
    """``(axis, value, seed, scene, folder)`` of the folder's pairs: two axes, ``real``
    pseudo-real scenes (axis ``real``, one pair each, no value or seed)."""
    for axis, values in (("noise", (0.0, 4.0, 12.0)), ("disparity_scale", (0.5, 1.0))):
        for value in values:
            for seed in seeds:
                yield axis, value, seed, f"bands-{seed}", f"pairs/{axis}/{value:g}_s{seed}"
    for k in range(real):
        yield "real", None, None, f"numpy:bands/{10 + k}", f"pairs/real/numpy_bands_{10 + k}"


def make_validate_dir(out: Path, matchers: dict, *, seeds=(0, 1, 2), real: int = 0) -> Path:
    """A validate folder: pairs, estimates of ``matchers`` (spec -> callable), results.csv."""
    rows = []
    for axis, value, seed, scene, sample in _samples(seeds, real):
        pair_seed = int(scene.rsplit("/", 1)[-1]) if seed is None else seed
        rng = np.random.default_rng(pair_seed)
        left, right, gt, labels = _pair(pair_seed, value if axis == "disparity_scale" else 1.0)
        if axis == "noise":
            left = np.clip(left + rng.normal(0, value, left.shape), 0, 255).astype(np.uint8)
        gt = gt.copy()
        gt[:, :2] = np.inf  # a strip without ground truth, as at a real border
        folder = out / sample
        folder.mkdir(parents=True, exist_ok=True)
        rgb = [np.repeat(v[..., None], 3, axis=2) for v in (left, right)]
        atomic_write_bytes(folder / "im0.png", encode_png(rgb[0]))
        atomic_write_bytes(folder / "im1.png", encode_png(rgb[1]))
        write_pfm(folder / "disp0GT.pfm", gt.astype(np.float32))
        cols = np.arange(gt.shape[1])[None, :]
        known = np.isfinite(gt)
        occluded = known & (cols < np.where(known, gt, 0))
        edges = np.zeros_like(known)
        edges[1:] |= labels[1:] != labels[:-1]
        masks = {"all": known, "nonocc": known & ~occluded, "occluded": occluded,
                 "textureless": np.zeros_like(known), "discontinuity": edges & known}
        for name, m in masks.items():
            atomic_write_bytes(folder / f"mask_{name}.png",
                               encode_png(m.astype(np.uint8) * 255))
        for spec, f in matchers.items():
            est, error, rel = None, "", ""
            try:
                est = np.asarray(f(rgb[0], rgb[1], max_disparity=16), np.float32)
                rel = (f"estimates/{re.sub(r'[^a-z0-9]+', '_', spec)}/"
                       f"{sample.removeprefix('pairs/')}.pfm")
                (out / rel).parent.mkdir(parents=True, exist_ok=True)
                write_pfm(out / rel, est)
            except Exception as exc:  # noqa: BLE001 - recorded, like the real sweep
                error = f"crashed: {type(exc).__name__}: {exc}"
            for region in REGIONS:
                rows.append({"matcher": spec, "axis": axis, "value": value, "seed": seed,
                             "scene": scene, "region": region, **_scores(est, gt, masks[region]),
                             "seconds": 0.01, "mpix_disp_per_s": 3.7 if est is not None
                             else None, "error": error, "sample": sample,
                             "estimate": rel})
    with (out / "results.csv").open("w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow(["" if r.get(c) is None else r.get(c) for c in COLUMNS])
    return out


def _pair(seed: int, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(left, right, disparity, labels)``: three slanted planar bands warped from band-limited noise."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(seed)
    h, w = 48, 64
    noise = gaussian_filter(rng.random((h, w)), 0.8)
    right = np.round((noise - noise.min()) / np.ptp(noise) * 255).astype(np.uint8)
    labels = np.repeat(np.arange(3), [16, 16, 16])[:, None] * np.ones((1, w), np.int64)
    xs = np.arange(w)[None, :]
    disparity = np.zeros((h, w))
    for k in range(3):
        a, b = rng.uniform(3, 10), rng.uniform(-0.04, 0.04)
        disparity[labels == k] = np.broadcast_to(scale * (a + b * xs), (h, w))[labels == k]
    left, _ = _warp(right, disparity)
    return left, right, disparity, labels


def _warp(right: np.ndarray, disparity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    h, w = right.shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    src = np.clip(xs - disparity, 0.0, w - 1.0)
    x0 = np.floor(src).astype(np.int64)
    x1 = np.minimum(x0 + 1, w - 1)
    t = src - x0
    r = right.astype(np.float64)
    rows = ys.astype(np.int64)
    return np.round((1 - t) * r[rows, x0] + t * r[rows, x1]).astype(np.uint8), right


def _ct5(left, right, *, max_disparity):
    return match(left, right, method="ct", window=5, max_disparity=max_disparity).disparity


MATCHER, REFERENCES = "py:poor.py:census3", ("ct:9", "bm:9")
#: The baseline's rows: CT-5 under the label a run gives a baseline's matcher.
BASELINE = "baseline ct:5"


@pytest.fixture(scope="module")
def validate_dir(tmp_path_factory) -> Path:
    out = make_validate_dir(tmp_path_factory.mktemp("validate"),
                            {MATCHER: _poor, "ct:9": _ct9, "bm:9": _bm, BASELINE: _ct5}, real=2)
    run_battery(_poor, out, suite="quick", name="census3")
    write_report(out, matcher=MATCHER, references=REFERENCES,
                 baseline=(BASELINE, out / "a-baseline-folder-with-a-long-name" / ("x" * 120)))
    return out


def test_t_interval_and_pairing_by_hand() -> None:
    m, h, n = t_interval([0.1, 0.3])
    assert (round(m, 6), n) == (0.2, 2) and h == pytest.approx(12.7062 * 0.1, rel=1e-4)  # s = 0.1 sqrt(2), s / sqrt(2) = 0.1
    rows = [{"matcher": k, "axis": "a", "value": v, "seed": s, "region": "all", "bad_2": b}
            for k, v, s, b in [("m", 1.0, 0, 0.5), ("r", 1.0, 0, 0.2), ("m", 1.0, 1, 0.4),
                               ("r", 2.0, 1, 0.1), ("r", 1.0, 1, None)]]
    assert paired_differences(rows, "m", "r", axis="a", region="all") == [pytest.approx(0.3)]


def test_report_sections(validate_dir: Path) -> None:
    page = (validate_dir / "report.html").read_text()
    for heading in ("Summary", "Axes", "Worst samples", "Properties"):
        assert f"<h2>{heading}</h2>" in page
    assert "against ct:9" in page and "against bm:9" in page
    assert "<h3>Speed</h3>" in page and "<td>bm:9</td><td>17</td><td>0.01</td><td>3.7</td>" in page
    # the 3 x 3 census is clearly worse than CT-9 on noise-free warped pairs: the sentence
    # names the axis, the folded table holds every cell
    assert re.search(r"Most worse than ct:9: [^\n]*<b>noise</b>", page)
    assert page.count("<details>") == 3 and "<td>noise</td><td></td><td>all</td>" in page
    assert page.count("<img class='heatmap'") == 3  # the baseline's, one per reference
    assert page.index(f"against {BASELINE}") < page.index("against ct:9")
    # three heatmaps, two axis plots, one worst sample per axis and real, counterexamples
    assert page.count("<img") >= 3 + 2 + 3
    assert page.count("data:image/svg+xml") == 5  # the heatmaps and the axis plots
    assert "<h2>Real scenes</h2>" in page and "<td>numpy:bands/11</td>" in page
    assert "src='http" not in page and 'src="http' not in page and "<script" not in page
    for uri in re.findall(r"src='([^']*)'", page):
        assert uri.startswith(("data:image/png;base64,", "data:image/svg+xml;base64,"))


def _svg(uri: str) -> str:
    import base64

    return base64.b64decode(uri.removeprefix("data:image/svg+xml;base64,")).decode()


def test_heatmap_one_cell_per_axis_region_with_marks_numbers_and_a_colour_bar() -> None:
    from synth.validate.differences import difference_table
    from synth.validate.figures import heatmap

    rows = [{"matcher": m, "axis": axis, "value": v, "seed": s, "scene": "", "region": g,
             "bad_2": b + (0.0 if g == "all" else 0.01 * s)}
            for axis, lift in (("noise", 0.05), ("blur", -0.04), ("gain", 0.0))
            for v in (1.0, 2.0) for s in (0, 1, 2) for g in ("all", "nonocc")
            for m, b in (("me", 0.2 + lift + 0.002 * (s - 1)), ("ref", 0.2))]
    rows += [{"matcher": m, "axis": "real", "value": None, "seed": None, "scene": scene,
              "region": "all", "bad_2": b} for scene, d in (("kitti:a", 0.03), ("kitti:b", 0.05))
             for m, b in (("me", 0.3 + d), ("ref", 0.3))]
    table = difference_table(rows, "me", ["ref"])
    svg = _svg(heatmap(table, "ref"))
    for label in ("noise", "blur", "gain", "real (2 scenes)", "kitti:a", "kitti:b",
                  "bad-2 difference (points)", "nonocc"):
        assert f">{label}</text>" in svg, label
    for number in ("+5.0", "-4.0", "+0.0", "+4.0", "+3.0"):  # noise, blur, gain, real, kitti:a
        assert f">{number}</text>" in svg, number
    # framed and bold: noise and blur (clear differences) in both regions; not gain, nor real
    # (two scenes that disagree), nor a single scene (no interval)
    assert svg.count("stroke-width='2'") == svg.count("font-weight='bold'>") == 4
    assert svg.count("fill='#ddd'") == 3 * 3 + 3 * 4  # no pixel: 3 regions per axis, 4 per real
    assert "≥ +5</text>" in svg and "≤ -5</text>" in svg  # the colour bar's ends


def test_summary_sentences_name_the_extreme_axes(validate_dir: Path) -> None:
    from synth.validate.differences import difference_table, read_results

    page = (validate_dir / "report.html").read_text()
    table = difference_table(read_results(validate_dir / "results.csv"), MATCHER, ["ct:9"])
    worse = sorted({r["axis"] for r in table if r["verdict"] == "worse" and not r["scene"]})
    sentence = re.search(r"<p class='worse'>Most worse than ct:9: (.*?)</p>", page).group(1)
    assert sorted(re.findall(r"<b>([^<]+)</b>", sentence)) == sorted(
        "real scenes" if a == "real" else a for a in worse)[:3]
    assert "<p class='better'>Clearly better than ct:9 on no axis.</p>" in page


def test_worst_samples_come_from_different_axes(validate_dir: Path) -> None:
    page = (validate_dir / "report.html").read_text()
    section = page[page.index("<h2>Worst samples</h2>"):page.index("<h2>Properties</h2>")]
    heads = re.findall(r"<h3>(.*?): bad-2", section)
    axes = [h.split(" = ")[0] if " = " in h else "real" for h in heads]
    assert len(heads) == 3 and len(set(axes)) == 3  # noise, disparity_scale and real


def test_report_lists_every_property_with_its_counterexample(validate_dir: Path) -> None:
    page = (validate_dir / "report.html").read_text()
    import json

    doc = json.loads((validate_dir / "properties.json").read_text())
    for p in doc["properties"]:
        assert p["name"] in page
        for rel in p["counterexample"] or []:
            assert f"alt='{rel}'" in page


def test_report_without_inputs_says_so(tmp_path: Path) -> None:
    page = write_report(tmp_path, matcher="ct:9", references=["sgbm:5"]).read_text()
    assert "No results.csv" in page and "No properties.json" in page


def test_report_notes_failed_samples_and_unknown_reference(tmp_path: Path) -> None:
    def crashing(left, right, *, max_disparity):
        raise RuntimeError("no GPU")

    out = make_validate_dir(tmp_path, {"cmd:./crash": crashing, "ct:9": _ct9}, seeds=(0, 1))
    page = write_report(out, matcher="cmd:./crash", references=["ct:9", "sgbm:5"]).read_text()
    assert "failed on 10 sample(s)" in page and "no GPU" in page
    assert "No rows of the reference sgbm:5" in page
    assert "<h2>Worst samples</h2>" in page  # failed samples are drawn as "no estimate"


# --------------------------------------------------------------------------- in a browser
def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


_CHECK_IMAGES = """
<script>
window.addEventListener('load', () => {
  const imgs = Array.from(document.images);
  const broken = imgs.filter(i => !i.complete || i.naturalWidth === 0).map(i => i.alt);
  document.querySelectorAll('details').forEach(d => { d.open = true; });
  const root = document.documentElement;
  const out = document.createElement('pre');
  out.id = 'image-check';
  out.textContent = 'images=' + imgs.length + ' broken=' + JSON.stringify(broken) +
    ' scroll=' + root.scrollWidth + ' view=' + root.clientWidth;
  document.body.appendChild(out);
});
</script>
"""


@pytest.mark.slow
def test_report_has_no_broken_image_in_chromium(validate_dir: Path, tmp_path: Path,
                                                require_or_skip) -> None:
    """Chromium, 1280 px wide, loads a copy of the page with a load-time check appended and
    dumps the DOM.

    ``--dump-dom`` prints the DOM after the load event, so the check's result (every <img>
    ``complete`` with ``naturalWidth > 0``; with every ``<details>`` opened, the page no wider
    than the window: no horizontal scroll bar) is in the output; the same check on a page with a
    truncated PNG and one with a too-wide table must see them. A screenshot of the page is taken
    too and must be a non-blank PNG. ``--no-sandbox`` because CI runs as root.
    """
    exe = _chromium()
    if exe is None:
        for env in ("STEREOFORGE_REQUIRE_GL", "STEREOFORGE_REQUIRE_CHROMIUM"):
            if os.environ.get(env, "") not in ("", "0", "false", "no"):
                pytest.fail(f"chromium not found ({env}=1 forbids skipping); "
                            "apt-get install chromium")
        require_or_skip("chromium not found; apt-get install chromium",
                        env="STEREOFORGE_REQUIRE_CHROMIUM")
    flags = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
             "--hide-scrollbars", f"--user-data-dir={tmp_path / 'profile'}",
             "--virtual-time-budget=10000", "--window-size=1280,900"]

    def check(page: str, name: str) -> tuple[int, str, bool]:
        """(images, broken ones, whether the page scrolls horizontally)."""
        probe = tmp_path / name
        probe.write_text(page.replace("</body>", _CHECK_IMAGES + "</body>"))
        dom = subprocess.run([*flags, "--dump-dom", probe.as_uri()], capture_output=True,
                             text=True, timeout=120, check=True).stdout
        found = re.search(r"images=(\d+) broken=(\[.*?\]) scroll=(\d+) view=(\d+)", dom)
        assert found, f"the check did not run; chromium printed: {dom[:500]!r}"
        assert int(found.group(4)) == 1280, found.group(0)
        return int(found.group(1)), found.group(2), int(found.group(3)) > int(found.group(4))

    page = (validate_dir / "report.html").read_text()
    assert check(page, "probe.html") == (page.count("<img"), "[]", False)
    # the check sees a broken image (a truncated PNG) and a page wider than the window
    bad = page.replace("<h2>Summary</h2>",
                       "<img alt='truncated' src='data:image/png;base64,iVBORw0KGgo='><h2>Summary</h2>")
    assert check(bad, "bad.html") == (page.count("<img") + 1, '["truncated"]', False)
    wide = page.replace("<h2>Summary</h2>", "<details><summary>x</summary><table><tr><td>"
                        + "x" * 400 + "</td></tr></table></details><h2>Summary</h2>")
    assert check(wide, "wide.html")[2]
    shot = tmp_path / "shot.png"
    subprocess.run([*flags, f"--screenshot={shot}", (validate_dir / "report.html").as_uri()],
                   capture_output=True, timeout=120, check=True)
    from matcher.io import read_image

    pixels = read_image(shot)
    assert pixels.shape[:2] == (900, 1280) and pixels.std() > 10  # not a blank page
