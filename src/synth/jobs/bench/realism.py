"""The realism target: do matchers find our pairs as hard as real scenes, and rank them alike?

``stereoforge bench realism`` renders ``count`` pairs of a dataset config and runs the same three
matchers on them and on real scenes with ground truth:

- the six Middlebury 2005/2006 scenes of the seed paper (``third/`` of ``--data``: Moebius,
  Reindeer, Flowerpots, Cloth2, Midd1, Baby1; disparity = ``disp1.png / 3``, 0 = unknown);
- Middlebury 2014 *Motorcycle* as shipped by scikit-image (``skimage.data.stereo_motorcycle``,
  741 x 500, no download), a seventh reference reported beside the six (not in their mean).

The measure is the one of the issue's target: **bad-3 over all pixels with ground truth, a
missing estimate counted bad** (:func:`matcher.evaluate` ``pobmp`` with ``delta=3``,
``region="all"``). Matchers: CT-9 and CT-21 (census, winner-takes-all, no post-processing) and
OpenCV SGBM with a 5 x 5 block (:func:`matcher.match` defaults). Search ranges: 0..84 for the
third-size scenes (covers their largest disparity, 76), 0..64 for Motorcycle (largest 60), and
for the synthetic set ``ceil(1.1 * d_max)`` rounded up to a multiple of 4, with ``d_max`` the
largest ground-truth disparity over its pairs (the same ~10 % margin as the real scenes').

The target holds when, for every matcher, the synthetic mean lies within ``tolerance`` (5)
points of the six scenes' mean, and the three matchers rank the same way on both (ranking by
mean bad-3, best first).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["MATCHERS", "REAL_SCENES", "RealismResult", "bench_realism", "format_verdict"]

#: (label, method, window) of the matchers compared.
MATCHERS: tuple[tuple[str, str, int], ...] = (("CT-9", "ct", 9), ("CT-21", "ct", 21),
                                              ("SGBM-5", "sgbm", 5))
#: The seed paper's six scenes, as folders of ``third/``.
REAL_SCENES = ("Moebius", "Reindeer", "Flowerpots", "Cloth2", "Midd1", "Baby1")
_THIRD_RANGE = 84
_MOTORCYCLE_RANGE = 64


@dataclass(frozen=True)
class RealismResult:
    """Per-sample rows, the per-set summary rows and the verdict of one run."""

    samples: list[dict]
    summary: list[dict]
    within: dict[str, bool]
    same_ranking: bool
    ranking_real: list[str]
    ranking_synthetic: list[str]

    @property
    def passed(self) -> bool:
        """Every matcher within the tolerance and the same ranking."""
        return all(self.within.values()) and self.same_ranking


def _bad3(left: np.ndarray, right: np.ndarray, gt: np.ndarray, max_disparity: int) -> dict:
    from matcher import evaluate, match

    row = {}
    for label, method, window in MATCHERS:
        est = match(left, right, method=method, window=window,
                    max_disparity=max_disparity).disparity
        row[label] = round(float(evaluate(est, gt, delta=3.0, region="all").pobmp), 3)
    return row


def _real_rows(data: Path | None) -> list[dict]:
    from synth.formats import resolve_spec

    rows = []
    if data is not None:
        for scene in REAL_SCENES:
            (ref,) = resolve_spec(f"middlebury:{data / 'third' / scene}:3")
            s = ref.read()
            rows.append({"set": "middlebury-third", "sample": scene, "max_disparity": _THIRD_RANGE,
                         **_bad3(s.left, s.right, s.disp_left, _THIRD_RANGE)})
    s = resolve_spec("skimage:motorcycle")[0].read()
    rows.append({"set": "motorcycle-2014", "sample": "Motorcycle", "max_disparity":
                 _MOTORCYCLE_RANGE, **_bad3(s.left, s.right, s.disp_left, _MOTORCYCLE_RANGE)})
    return rows


def _synthetic_rows(config: str, dataset_dir: Path, count: int, workers: int,
                    backend: str) -> list[dict]:
    from synth.dataset import run_dataset
    from synth.dataset.loader import StereoDataset

    run_dataset(config, dataset_dir, count=count, workers=workers, backend=backend,
                progress=False)
    data = StereoDataset(dataset_dir)
    samples = [data[i] for i in range(min(count, len(data)))]
    d_max = max(float(np.max(s["disp"], where=s["valid"], initial=0.0)) for s in samples)
    search = max(4, 4 * math.ceil(math.ceil(1.1 * d_max) / 4))
    return [{"set": str(config), "sample": f"{i:06d}", "max_disparity": search,
             **_bad3(s["left"], s["right"], s["disp"], search)} for i, s in enumerate(samples)]


def _mean_row(rows: Sequence[dict], name: str) -> dict:
    row: dict = {"set": name, "sample": f"mean of {len(rows)}", "max_disparity": ""}
    for label, _, _ in MATCHERS:
        row[label] = round(float(np.mean([r[label] for r in rows])), 2)
    return row


def _ranking(row: dict) -> list[str]:
    return sorted((label for label, _, _ in MATCHERS), key=lambda m: row[m])


def bench_realism(*, config: str = "flying", count: int = 20, data: Path | None = None,
                  out: Path, workers: int = 1, backend: str = "auto", tolerance: float = 5.0,
                  log: Callable[[str], None] | None = None) -> RealismResult:
    """Run the realism comparison; the synthetic pairs are kept under ``out/pairs/<config>``
    (a rerun completes and reuses them: the dataset engine resumes)."""
    say = log or (lambda _m: None)
    say(f"real scenes ({'6 Middlebury third-size + ' if data else ''}Motorcycle) ...")
    real = _real_rows(data)
    say(f"{count} pairs of {config} ...")
    name = Path(config).stem if os.sep in str(config) or str(config).endswith(".toml") else config
    synthetic = _synthetic_rows(config, out / "pairs" / name, count, workers, backend)
    six = [r for r in real if r["set"] == "middlebury-third"]
    summary = []
    if six:
        summary.append(_mean_row(six, "middlebury-third"))
    summary.append(_mean_row([r for r in real if r["set"] == "motorcycle-2014"], "motorcycle-2014"))
    synth_mean = _mean_row(synthetic, str(config))
    summary.append(synth_mean)
    reference = summary[0]
    within = {label: abs(synth_mean[label] - reference[label]) <= tolerance
              for label, _, _ in MATCHERS}
    for row in summary:
        row.update({f"{label} diff": round(row[label] - reference[label], 2)
                    for label, _, _ in MATCHERS})
        row["ranking"] = " < ".join(_ranking(row))
    return RealismResult(real + synthetic, summary, within,
                         _ranking(reference) == _ranking(synth_mean), _ranking(reference),
                         _ranking(synth_mean))


def format_verdict(result: RealismResult, *, tolerance: float = 5.0) -> str:
    """Lines saying whether the target holds, per matcher and for the ranking."""
    reference = result.summary[0]
    synthetic = result.summary[-1]
    lines = [f"reference: {reference['set']} ({reference['sample']}); target: every matcher "
             f"within +-{tolerance:g} points of it, same ranking"]
    for label, _, _ in MATCHERS:
        diff = synthetic[label] - reference[label]
        lines.append(f"  {label}: synthetic {synthetic[label]:.2f} % vs real "
                     f"{reference[label]:.2f} % ({diff:+.2f}): "
                     f"{'within' if result.within[label] else 'OUTSIDE'}")
    lines.append(f"  ranking real: {' < '.join(result.ranking_real)}; synthetic: "
                 f"{' < '.join(result.ranking_synthetic)}: "
                 f"{'same' if result.same_ranking else 'DIFFERENT'}")
    lines.append(f"realism target {'met' if result.passed else 'NOT met'}")
    return "\n".join(lines)
