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

``matchers`` (``--matchers``: MATCHER strings, e.g. ``ct:9,ct:21,bm:9,sgbm:5,sgbm:11``)
replaces the three; ``real`` (``--real SPEC``, repeatable: ``validate --real``'s SPECs such as
``eth3d:DIR``, ``drivingstereo:DIR``, ``kitti:DIR``) adds real sets outside the lab, each
scored with the same measure on every scene (search range as ``validate`` takes it: a multiple
of 16 above the scene's largest disparity), with its mean row and ranking. For each set
:attr:`RealismResult.agreement` says which matcher it ranks best, where the synthetic pairs'
best matcher ranks there, and Spearman's rank correlation of the two rankings: what a user who
picks a matcher on our pairs would pick on that kind of real scene.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["MATCHERS", "REAL_SCENES", "RealismResult", "bench_realism", "format_verdict",
           "spearman"]

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
    #: Per real set (the references and every ``--real`` set): its best matcher, the rank there
    #: (1-based) of the synthetic pairs' best, and Spearman's rho of the two rankings.
    agreement: list[dict] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        """Every matcher within the tolerance and the same ranking."""
        return all(self.within.values()) and self.same_ranking


#: The label of each default matcher's MATCHER string (others are labelled by their string).
_LABELS = {f"{method}:{window}": label for label, method, window in MATCHERS}


def _matchers(specs: Sequence[str] | None) -> list[tuple[str, Callable]]:
    """(label, matcher) of each MATCHER string (default: :data:`MATCHERS`); a bad string fails
    here, before anything is rendered (:func:`matcher.adapters.resolve_matcher`)."""
    from matcher.adapters import resolve_matcher
    from stereoforge.errors import ParameterError

    specs = [f"{m}:{w}" for _, m, w in MATCHERS] if specs is None else [str(s) for s in specs]
    if len(specs) < 2 or len(set(specs)) != len(specs):
        raise ParameterError(f"--matchers: expected at least two distinct MATCHER strings, got "
                             f"{','.join(specs) or 'none'}")
    return [(_LABELS.get(s, s), resolve_matcher(s)) for s in specs]


def _bad3(matchers: Sequence[tuple[str, Callable]], left: np.ndarray, right: np.ndarray,
          gt: np.ndarray, max_disparity: int) -> dict:
    from matcher import evaluate

    row = {}
    for label, m in matchers:
        est = m(left, right, max_disparity=max_disparity)
        row[label] = round(float(evaluate(est, gt, delta=3.0, region="all").pobmp), 3)
    return row


def _real_rows(data: Path | None, matchers: Sequence[tuple[str, Callable]],
               real: Sequence[tuple[str, list]]) -> list[dict]:
    from synth.formats import resolve_spec
    from synth.validate.pairs import max_disparity_for
    from synth.validate.real import set_names

    rows = []
    if data is not None:
        for scene in REAL_SCENES:
            (ref,) = resolve_spec(f"middlebury:{data / 'third' / scene}:3")
            s = ref.read()
            rows.append({"set": "middlebury-third", "sample": scene, "max_disparity": _THIRD_RANGE,
                         **_bad3(matchers, s.left, s.right, s.disp_left, _THIRD_RANGE)})
    s = resolve_spec("skimage:motorcycle")[0].read()
    rows.append({"set": "motorcycle-2014", "sample": "Motorcycle", "max_disparity":
                 _MOTORCYCLE_RANGE, **_bad3(matchers, s.left, s.right, s.disp_left,
                                            _MOTORCYCLE_RANGE)})
    for name, (_, scenes) in zip(set_names([spec for spec, _ in real]), real):
        for scene in scenes:
            left, right, gt, _, _ = scene.load()
            search = max_disparity_for(gt, gt.shape[1])
            rows.append({"set": name, "sample": scene.ref.name, "max_disparity": search,
                         **_bad3(matchers, left, right, gt, search)})
    return rows


def spearman(a: Sequence[str], b: Sequence[str]) -> float:
    """Spearman's rank correlation of two rankings of the same items (best first).

    Examples
    --------
    >>> spearman(["x", "y", "z"], ["x", "y", "z"]), spearman(["x", "y", "z"], ["z", "y", "x"])
    (1.0, -1.0)
    """
    n = len(a)
    rank = {m: i for i, m in enumerate(b)}
    d2 = sum((i - rank[m]) ** 2 for i, m in enumerate(a))
    return round(1.0 - 6.0 * d2 / (n * (n * n - 1)), 3)


def _synthetic_rows(config: str, dataset_dir: Path, count: int, workers: int,
                    backend: str, matchers: Sequence[tuple[str, Callable]]) -> list[dict]:
    from synth.dataset import run_dataset
    from synth.dataset.loader import StereoDataset

    run_dataset(config, dataset_dir, count=count, workers=workers, backend=backend,
                progress=False)
    data = StereoDataset(dataset_dir)
    samples = [data[i] for i in range(min(count, len(data)))]
    d_max = max(float(np.max(s["disp"], where=s["valid"], initial=0.0)) for s in samples)
    search = max(4, 4 * math.ceil(math.ceil(1.1 * d_max) / 4))
    return [{"set": str(config), "sample": f"{i:06d}", "max_disparity": search,
             **_bad3(matchers, s["left"], s["right"], s["disp"], search)}
            for i, s in enumerate(samples)]


def _mean_row(rows: Sequence[dict], name: str, labels: Sequence[str]) -> dict:
    row: dict = {"set": name, "sample": f"mean of {len(rows)}", "max_disparity": ""}
    for label in labels:
        row[label] = round(float(np.mean([r[label] for r in rows])), 2)
    return row


def _ranking(row: dict, labels: Sequence[str]) -> list[str]:
    return sorted(labels, key=lambda m: row[m])


def bench_realism(*, config: str = "flying", count: int = 20, data: Path | None = None,
                  out: Path, workers: int = 1, backend: str = "auto", tolerance: float = 5.0,
                  matchers: Sequence[str] | None = None, real: Sequence[str] = (),
                  log: Callable[[str], None] | None = None) -> RealismResult:
    """Run the realism comparison; the synthetic pairs are kept under ``out/pairs/<config>``
    (a rerun completes and reuses them: the dataset engine resumes). ``matchers`` and ``real``:
    see the module docstring; both are checked before anything is rendered."""
    say = log or (lambda _m: None)
    from synth.validate.real import resolve_real

    methods = _matchers(matchers)
    labels = [label for label, _ in methods]
    real = [(spec, resolve_real([spec])) for spec in real]  # a bad SPEC fails before any work
    say(f"real scenes ({'6 Middlebury third-size + ' if data else ''}Motorcycle"
        f"{''.join(f', {spec}' for spec, _ in real)}) ...")
    real_rows = _real_rows(data, methods, real)
    say(f"{count} pairs of {config} ...")
    name = Path(config).stem if os.sep in str(config) or str(config).endswith(".toml") else config
    synthetic = _synthetic_rows(config, out / "pairs" / name, count, workers, backend, methods)
    summary = [_mean_row([r for r in real_rows if r["set"] == s], s, labels)
               for s in dict.fromkeys(r["set"] for r in real_rows)]
    synth_mean = _mean_row(synthetic, str(config), labels)
    summary.append(synth_mean)
    reference = summary[0]
    within = {label: abs(synth_mean[label] - reference[label]) <= tolerance for label in labels}
    for row in summary:
        row.update({f"{label} diff": round(row[label] - reference[label], 2) for label in labels})
        row["ranking"] = " < ".join(_ranking(row, labels))
    ours = _ranking(synth_mean, labels)
    agreement = [{"set": row["set"], "best": _ranking(row, labels)[0],
                  f"rank of {ours[0]}": _ranking(row, labels).index(ours[0]) + 1,
                  "spearman": spearman(ours, _ranking(row, labels))} for row in summary[:-1]]
    return RealismResult(real_rows + synthetic, summary, within,
                         _ranking(reference, labels) == ours, _ranking(reference, labels), ours,
                         agreement)


def format_verdict(result: RealismResult, *, tolerance: float = 5.0) -> str:
    """Lines saying whether the target holds, per matcher and for the ranking."""
    reference = result.summary[0]
    synthetic = result.summary[-1]
    lines = [f"reference: {reference['set']} ({reference['sample']}); target: every matcher "
             f"within +-{tolerance:g} points of it, same ranking"]
    for label in result.within:
        diff = synthetic[label] - reference[label]
        lines.append(f"  {label}: synthetic {synthetic[label]:.2f} % vs real "
                     f"{reference[label]:.2f} % ({diff:+.2f}): "
                     f"{'within' if result.within[label] else 'OUTSIDE'}")
    lines.append(f"  ranking real: {' < '.join(result.ranking_real)}; synthetic: "
                 f"{' < '.join(result.ranking_synthetic)}: "
                 f"{'same' if result.same_ranking else 'DIFFERENT'}")
    lines.append(f"realism target {'met' if result.passed else 'NOT met'}")
    best = result.ranking_synthetic[0]
    for row in result.agreement:
        lines.append(f"  {row['set']}: best {row['best']}; {best} (best on {synthetic['set']}) "
                     f"ranks {row[f'rank of {best}']} of {len(result.ranking_synthetic)} there; "
                     f"Spearman {row['spearman']:+.2f}")
    return "\n".join(lines)
