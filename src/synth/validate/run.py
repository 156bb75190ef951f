"""``stereoforge validate``: sweep every axis, score a matcher and its references per region.

The run, resumable like a dataset (every record is written atomically; a rerun skips what is done
and verifies it):

1. **pairs**: every axis x value x seed of the suite (:mod:`synth.validate.axes`) is rendered
   once into ``pairs/...`` (:mod:`synth.validate.pairs`), with ``--workers`` GL processes, and
   every ``--real`` scene is written into ``pairs/real/...`` (:mod:`synth.validate.real`);
   with ``--baseline``, pairs the folder lacks are copied from the baseline, and the pairs must
   be the baseline's (:mod:`synth.validate.baseline`);
2. **estimates**: the matcher and each reference (``--against``) run on exactly those pairs, in
   this process, one after the other (``py:`` matchers in their own child process, see
   :mod:`matcher.adapters`); each writes ``estimates/<matcher>/<pair folder>.pfm`` and a
   ``.json`` record of its scores per region, seconds and error. A failure (crash, timeout,
   wrong shape) is recorded, scored as "no estimate", and the run goes on; the records of the
   references a baseline ran are copied from it, not computed;
3. ``results.csv`` (:data:`COLUMNS`), rebuilt from the records in a fixed order: matchers as
   given, axes in registry order, values, seeds, then the real scenes, regions
   (:data:`matcher.regions.REGIONS`); the same suite gives the same bytes except the timing
   columns ``seconds`` and ``mpix_disp_per_s``;
   then ``run.json`` (the run is finished) and ``differences.csv`` (paired differences against
   each reference and the baseline, :mod:`synth.validate.differences`);
4. the property battery (``properties.json``) and ``report.html``
   (:func:`_battery_and_report`).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from matcher.io import atomic_write_bytes

__all__ = ["COLUMNS", "DEFAULT_AGAINST", "ValidateResult", "estimates_folder", "plan",
           "run_validate"]

COLUMNS = ("matcher", "axis", "value", "seed", "scene", "region", "bad_0_5", "bad_1", "bad_2",
           "bad_4", "avgerr", "rms", "a50", "a90", "a99", "coverage", "seconds", "mpix_disp_per_s",
           "error", "sample", "estimate")
#: Timing columns: they differ between runs of the same suite.
TIMING_COLUMNS = ("seconds", "mpix_disp_per_s")
DEFAULT_AGAINST = ("ct:9", "sgbm:5")


@dataclass(frozen=True)
class ValidateResult:
    """What :func:`run_validate` did.

    Attributes
    ----------
    out : Path
    results : Path
        ``results.csv``.
    pairs_rendered, pairs_reused, estimates_computed, estimates_reused : int
    failed_properties : tuple of str
        Names of the required properties that failed (empty if the battery did not run).
    battery_ran : bool
    seconds : dict
        Wall time of each stage: ``pairs``, ``matching``, ``battery`` (battery and report) and
        ``total``.
    differences : tuple of dict
        The rows of ``differences.csv`` (:func:`synth.validate.differences.difference_table`).
    baseline : str or None
        The baseline's label in ``differences`` (``baseline <matcher>``), if one was given.
    pairs_copied : int
        Pairs copied from the baseline instead of rendered (counted in ``pairs_reused``).
    real : tuple of str
        The real scenes scored (those of the baseline when ``real`` was not given).
    """

    out: Path
    results: Path
    pairs_rendered: int
    pairs_reused: int
    estimates_computed: int
    estimates_reused: int
    failed_properties: tuple[str, ...]
    battery_ran: bool
    seconds: dict
    differences: tuple[dict, ...] = ()
    baseline: str | None = None
    pairs_copied: int = 0
    real: tuple[str, ...] = ()

    def regressions(self, points: float = 1.0) -> list[dict]:
        """The axis x region rows worse than the baseline by more than ``points`` bad-2 points
        with the 95 % interval above 0 (:func:`synth.validate.differences.regressions`)."""
        from synth.validate.differences import regressions

        return [] if self.baseline is None else regressions(self.differences, self.baseline,
                                                            points)


def plan(suite: str, axes: Sequence[str] | None = None) -> list:
    """The :class:`~synth.validate.pairs.PairSpec` of every pair of ``suite``, in results order."""
    from synth.validate.axes import AXES, SUITES, axis_config, get_axis
    from synth.validate.pairs import PairSpec

    if suite not in SUITES:
        raise ValueError(f"suite: expected one of {', '.join(SUITES)}, got {suite!r}")
    names = list(AXES) if axes is None else list(axes)
    out = []
    for name in names:
        axis = get_axis(name)
        for value in axis.values(suite):
            out.extend(PairSpec(name, value, seed, axis_config(suite, axis, value, seed))
                       for seed in SUITES[suite]["seeds"])
    return out


class _PairTask:
    """Picklable job of :func:`synth.dataset.engine.tasks.run_tasks`: render pair ``index`` of a
    plan."""

    preload = ("synth.validate.pairs", "synth.pair")

    def __init__(self, specs: list, out: Path, backend: str, width: int, height: int) -> None:
        self.specs, self.out, self.backend = specs, Path(out), backend
        self.width, self.height = width, height

    def __call__(self, index: int, renderer: Any) -> dict:
        from synth.validate.pairs import render_pair_folder

        return render_pair_folder(self.specs[index], self.out, renderer)


def _slug(spec: str) -> str:
    readable = re.sub(r"[^A-Za-z0-9]+", "_", spec).strip("_")[:40] or "matcher"
    return f"{readable}-{hashlib.sha256(spec.encode()).hexdigest()[:8]}"


def estimates_folder(spec: str) -> str:
    """Where a matcher's estimates go in a validate folder: ``estimates/<slug>``."""
    return f"estimates/{_slug(spec)}"


def _json(obj: Any) -> bytes:
    return (json.dumps(obj, indent=1, sort_keys=True, allow_nan=False) + "\n").encode()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _estimate_record(matcher: Any, spec: Any, sample: dict, out: Path) -> tuple[dict, bool]:
    """The matcher's record on one pair: reused if it verifies, else computed and written."""
    from matcher.io import write_pfm
    from matcher.regions import REGIONS, region_scores
    from synth.validate.pairs import read_pair_folder

    base = f"{estimates_folder(matcher.spec)}/{spec.folder.removeprefix('pairs/')}"
    rec_path, pfm_path = out / f"{base}.json", out / f"{base}.pfm"
    fingerprint = hashlib.sha256(f"{matcher.spec}\n{sample['fingerprint']}".encode()).hexdigest()
    try:
        old = json.loads(rec_path.read_bytes())
        if old.get("fingerprint") == fingerprint and (
                not old["estimate"] or _sha(out / old["estimate"]) == old["estimate_sha256"]):
            return old, False
    except (OSError, ValueError, KeyError, TypeError):
        pass
    left, right, gt, masks = read_pair_folder(out / spec.folder)
    d = int(sample["max_disparity"])
    outcome = matcher.run(left, right, max_disparity=d)
    record: dict[str, Any] = {"fingerprint": fingerprint, "matcher": matcher.spec,
                              "max_disparity": d, "seconds": outcome.seconds,
                              "error": outcome.error, "estimate": "", "estimate_sha256": ""}
    if outcome.disparity is not None:
        pfm_path.parent.mkdir(parents=True, exist_ok=True)
        write_pfm(pfm_path, outcome.disparity)
        record["estimate"] = f"{base}.pfm"
        record["estimate_sha256"] = _sha(pfm_path)
    scores = {n: region_scores(outcome.disparity, gt, masks[n]) for n in REGIONS}
    record["scores"] = {n: {k: v for k, v in s.items()} for n, s in scores.items()}
    record["pixels"] = int(gt.size)
    rec_path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(rec_path, _json(record), fsync=False)
    return record, True


def _cell(value: Any) -> Any:
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else value


def _results_csv(rows: list[dict]) -> bytes:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in rows:
        writer.writerow([_cell(row.get(c)) for c in COLUMNS])
    return buf.getvalue().encode()


def _rows(matcher: Any, spec: Any, record: dict) -> list[dict]:
    from matcher.regions import REGIONS

    seconds = float(record["seconds"])
    rate = None
    if record["error"] is None and seconds > 0:
        rate = record["pixels"] * record["max_disparity"] / seconds / 1e6
    base = {"matcher": matcher.spec, "axis": spec.axis, "value": spec.value, "seed": spec.seed,
            "scene": spec.scene, "seconds": seconds, "mpix_disp_per_s": rate,
            "error": record["error"] or "", "sample": spec.folder, "estimate": record["estimate"]}
    return [{**base, "region": n, **record["scores"][n]} for n in REGIONS]


def _pairs(specs: list, out: Path, suite: str, backend: str, workers: int, progress: bool,
           base: Any) -> tuple[dict[int, dict], int, int]:
    """Every pair folder of ``specs`` ready under ``out``: verified and reused, copied from the
    baseline ``base`` (if any), made (real scenes, in this process) or rendered (``workers``
    GL processes). ``({index: sample record}, rendered or made, copied)``."""
    from synth.dataset.engine.tasks import run_tasks
    from synth._util.progress import progress as progress_bar
    from synth.validate.axes import SUITES
    from synth.validate.baseline import adopt_pairs
    from synth.validate.pairs import PairSpec, verify_pair_folder
    from synth.validate.real import write_real_folder

    samples = {i: verify_pair_folder(s, out) for i, s in enumerate(specs)}
    adopted = {} if base is None else adopt_pairs(
        base, {i: specs[i] for i, rec in samples.items() if rec is None}, out)
    samples.update(adopted)
    pending = [i for i, rec in samples.items() if rec is None]
    for i in [i for i in pending if not isinstance(specs[i], PairSpec)]:
        samples[i] = write_real_folder(specs[i], out)
    synthetic = [i for i in pending if isinstance(specs[i], PairSpec)]
    size = SUITES[suite]
    task = _PairTask(specs, out, backend, size["width"], size["height"])
    bar = progress_bar(total=len(specs), initial=len(specs) - len(synthetic), enabled=progress,
                       desc=f"validate {suite}: pairs", unit="pair")
    try:
        for index, record in run_tasks(task, synthetic, workers=workers):
            samples[index] = record
            bar.update(1)
    finally:
        bar.close()
    return samples, len(pending), len(adopted)


def _battery_and_report(matcher: Any, out: Path, suite: str, references: Sequence[str],
                        rows: list[dict], baseline: tuple[str, Path] | None) -> tuple[str, ...]:
    """Run the property battery and write report.html; the names of failed required properties.

    The only place that calls :mod:`synth.validate.properties` and :mod:`synth.validate.report`.
    """
    from synth.validate.properties import run_battery
    from synth.validate.report import write_report

    entries = run_battery(matcher, out, suite=suite, name=matcher.name)
    write_report(out, matcher=matcher.spec, references=list(references), rows=rows,
                 baseline=baseline)
    return tuple(e["name"] for e in entries if e.get("required") and not e.get("passed"))


def run_validate(matcher: str, *, out: str | Path, suite: str = "quick",
                 against: Sequence[str] = DEFAULT_AGAINST, workers: int = 1,
                 timeout: float = 60.0, backend: str = "auto", progress: bool = True,
                 axes: Sequence[str] | None = None, battery: bool = True,
                 real: Sequence[str] = (), baseline: str | Path | None = None,
                 log: Callable[[str], None] | None = None) -> ValidateResult:
    """Validate ``matcher`` (a MATCHER string) on every axis of ``suite`` against references.

    Parameters
    ----------
    matcher : str
        See :func:`matcher.adapters.resolve_matcher`.
    out : str or Path
        Output folder (created; what is already there and verifies is reused).
    suite : {"quick", "full"}
    against : sequence of str
        Reference MATCHER strings, run on the same pairs (a repeat of ``matcher`` is dropped).
    workers : int
        Processes rendering the pairs (one GL renderer each; 1 renders in this process).
    timeout : float
        Seconds per pair for ``py:`` and ``cmd:`` matchers.
    axes : sequence of str, optional
        Only these axes (default: every registered axis).
    battery : bool
        Run the property battery and write the report (off: pairs, estimates and results only).
    real : sequence of str
        ``--real`` SPECs (:mod:`synth.validate.real`): real scenes scored beside the axes. With a
        ``baseline`` and none given, the baseline's.
    baseline : str or Path, optional
        A finished validate folder (:mod:`synth.validate.baseline`) whose matcher this one is
        compared with, on identical pairs; its pairs and its references' estimates are reused.
    log : callable, optional
        Told what the user should know before the work starts (where a real scene's divisor
        came from, :attr:`synth.validate.real.RealSpec.note`).

    Returns
    -------
    ValidateResult
    """
    from matcher.adapters import resolve_matcher
    from synth.validate.axes import AXES
    from synth.validate.baseline import (RUN_RECORD, adopt_estimates, baseline_label,
                                         check_same_pairs, load_run, run_record)
    from synth._util.progress import progress as progress_bar
    from synth.validate.differences import difference_table, differences_csv
    from synth.validate.pairs import record_digest
    from synth.validate.real import resolve_real

    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers: expected an int >= 1, got {workers!r}")
    clock = [time.perf_counter()]
    seconds: dict[str, float] = {}

    def lap(stage: str) -> None:
        now = time.perf_counter()
        seconds[stage] = now - clock[-1]
        clock.append(now)

    axis_names = list(AXES) if axes is None else list(axes)
    base = None if baseline is None else load_run(baseline)
    if base is not None and not real:  # the baseline's real scenes, as its pairs are taken
        real = base.real_specs
    reals = resolve_real(real)
    for r in reals:
        if r.note is not None and log is not None:
            log(r.note)
    specs = [*plan(suite, axis_names), *reals]
    if base is not None:
        check_same_pairs(base, suite=suite, axes=axis_names, real=[r.scene for r in reals],
                         pairs={}, folder=Path(out))
    main = resolve_matcher(matcher, timeout=timeout)
    refs = [resolve_matcher(a, timeout=timeout) for a in against if a.strip() != main.spec]
    matchers = [main, *[r for i, r in enumerate(refs) if r.spec not in
                        {x.spec for x in refs[:i]}]]
    folders = {m.spec: estimates_folder(m.spec) for m in matchers}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    samples, made, copied = _pairs(specs, out, suite, backend, workers, progress, base)
    digests = {s.folder: record_digest(out / s.folder) for s in specs}  # verified above
    if base is not None:
        check_same_pairs(base, suite=suite, axes=axis_names, real=[r.scene for r in reals],
                         pairs=digests, folder=out)
        adopt_estimates(base, [m.spec for m in matchers[1:]], specs, out, folders)
    lap("pairs")
    rows, computed, reused = [], 0, 0
    bar = progress_bar(total=len(specs) * len(matchers), enabled=progress,
                       desc=f"validate {suite}: matching", unit="run")
    try:
        for m in matchers:
            try:
                for i, spec in enumerate(specs):
                    record, fresh = _estimate_record(m, spec, samples[i], out)
                    computed, reused = computed + fresh, reused + (not fresh)
                    rows.extend(_rows(m, spec, record))
                    bar.update(1)
            finally:
                m.close()
    finally:
        bar.close()
    results = atomic_write_bytes(out / "results.csv", _results_csv(rows), fsync=False)
    atomic_write_bytes(out / RUN_RECORD, run_record(
        matcher=main.spec, references=[m.spec for m in matchers[1:]], suite=suite,
        axes=axis_names, real=[r.scene for r in reals], pairs=digests, estimates=folders),
        fsync=False)
    others = [m.spec for m in matchers[1:]]
    compared = None
    if base is not None:
        label = baseline_label(base)
        rows = rows + base.rows_of(base.matcher, label=label)
        others, compared = [label, *others], (label, base.folder)
    table = difference_table(rows, main.spec, others)
    atomic_write_bytes(out / "differences.csv", differences_csv(table), fsync=False)
    lap("matching")
    failed: tuple[str, ...] = ()
    if battery:
        failed = _battery_and_report(main, out, suite, [m.spec for m in matchers[1:]], rows,
                                     compared)
        main.close()
    lap("battery")
    seconds["total"] = clock[-1] - clock[0]
    return ValidateResult(out=out, results=results, pairs_rendered=made,
                          pairs_reused=len(specs) - made, estimates_computed=computed,
                          estimates_reused=reused, failed_properties=failed,
                          battery_ran=battery, seconds=seconds, differences=tuple(table),
                          baseline=None if base is None else baseline_label(base),
                          pairs_copied=copied, real=tuple(r.scene for r in reals))
