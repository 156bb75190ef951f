"""Earlier validate runs as baselines: ``--baseline DIR`` and ``--compare A B``.

A **finished** validate folder holds ``results.csv`` and ``run.json`` (:func:`run_record`,
written after it; :func:`load_run` refuses a ``results.csv`` that is empty, cut short or lacks a
row of a matcher, pair and region the run scored): the matcher, the references, the suite, the axes, the real scenes, and for
every pair folder the SHA-256 of its ``files.json`` (which lists the size and SHA-256 of each of
its files). Two runs compare only on identical pairs (:func:`check_same_pairs`): the same
suite, axes and real scenes, and per pair the same digest, or files that differ by encoding
only (the same pixels and values in other bytes, :mod:`synth.dataset.compare`). Anything else
is refused with one :class:`~stereoforge.errors.DatasetError` naming the difference.

With ``--baseline`` and no ``--real``, the run takes the baseline's real scenes (the ``--real``
SPECs its pair folders record, :attr:`FinishedRun.real_specs`); a different set is refused.
With ``--baseline``, pairs missing from the new folder are copied from the baseline instead
of rendered (:func:`adopt_pairs`), and so are the estimates of every reference the baseline ran
(:func:`adopt_estimates`: references are not matched again). The baseline's matcher enters the
comparison under the label :func:`baseline_label`.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
import shutil
from pathlib import Path
from typing import Sequence

from stereoforge.errors import DatasetError

__all__ = ["RUN_RECORD", "FinishedRun", "run_record", "load_run", "baseline_label",
           "check_same_pairs", "adopt_pairs", "adopt_estimates", "compare_runs"]

RUN_RECORD = "run.json"
_VERSION = 1


@dataclasses.dataclass(frozen=True)
class FinishedRun:
    """What :func:`load_run` read from a finished validate folder."""

    folder: Path
    matcher: str
    references: tuple[str, ...]
    suite: str
    axes: tuple[str, ...]
    real: tuple[str, ...]
    pairs: dict[str, str]
    estimates: dict[str, str]
    rows: list[dict]
    real_specs: tuple[str, ...] = ()

    def rows_of(self, matcher: str, *, label: str | None = None) -> list[dict]:
        """The results rows of ``matcher``, their ``matcher`` column set to ``label``."""
        return [{**r, "matcher": label or matcher} for r in self.rows if r["matcher"] == matcher]


def run_record(*, matcher: str, references: Sequence[str], suite: str, axes: Sequence[str],
               real: Sequence[str], pairs: dict[str, str], estimates: dict[str, str]) -> bytes:
    """The bytes of ``run.json``: ``pairs`` maps pair folders to their digest
    (:func:`synth.validate.pairs.folder_digest`), ``estimates`` matchers to their folder."""
    from synth._util.json_records import json_bytes

    return json_bytes({"version": _VERSION, "matcher": matcher, "references": list(references),
                       "suite": suite, "axes": list(axes), "real": list(real),
                       "pairs": pairs, "estimates": estimates})


def load_run(folder: str | Path, *, what: str = "--baseline") -> FinishedRun:
    """Read a finished validate folder; :class:`DatasetError` (``what`` in front) if it is not."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DatasetError(f"{what} {folder}: not a folder; give a folder `stereoforge "
                           "validate` wrote")
    try:
        doc = json.loads((folder / RUN_RECORD).read_bytes())
        run = FinishedRun(folder, str(doc["matcher"]), tuple(doc["references"]),
                          str(doc["suite"]), tuple(doc["axes"]), tuple(doc["real"]),
                          dict(doc["pairs"]), dict(doc["estimates"]),
                          _complete_results(folder, doc, what), _real_specs(folder, doc["pairs"]))
    except DatasetError:
        raise
    except FileNotFoundError as exc:
        raise DatasetError(f"{what} {folder}: not a finished validate folder (no "
                           f"{Path(exc.filename).name}); run `stereoforge validate ... --out "
                           f"{folder}` to the end first") from None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise DatasetError(f"{what} {folder}: unreadable {RUN_RECORD} or results.csv "
                           f"({type(exc).__name__}: {exc}); run `stereoforge validate` into "
                           "it again") from None
    return run


def _complete_results(folder: Path, doc: dict, what: str) -> list[dict]:
    """The rows of ``folder/results.csv`` if it is whole: every column, every field of every
    row, and a row for each matcher, pair and region ``run.json`` names."""
    from matcher.regions import REGIONS
    from synth.validate.differences import read_results

    path = folder / "results.csv"
    data = path.read_bytes()
    where = f"{what} {folder}: results.csv"
    fix = f"run `stereoforge validate ... --out {folder}` again to rebuild it"
    if not data.strip():
        raise DatasetError(f"{where} is empty; {fix}")
    header = data.split(b"\n", 1)[0].decode("utf-8", "replace").strip().split(",")
    lacking = [c for c in _READ_COLUMNS if c not in header]
    if lacking:
        raise DatasetError(f"{where} has no column {', '.join(lacking)}; {fix}")
    if not data.endswith(b"\n"):
        raise DatasetError(f"{where} is cut short (its last line is incomplete); {fix}")
    for n, fields in enumerate(csv.reader(io.StringIO(data.decode("utf-8"))), start=1):
        if len(fields) != len(header):
            raise DatasetError(f"{where}: line {n} has {len(fields)} of {len(header)} fields; "
                               f"{fix}")
    rows = read_results(path)
    if not rows:
        raise DatasetError(f"{where} holds a header and no rows; {fix}")
    have = {(r["matcher"], r["sample"], r["region"]) for r in rows}
    for m in [doc["matcher"], *doc["references"]]:
        for rel in doc["pairs"]:
            for region in REGIONS:
                if (m, rel, region) not in have:
                    raise DatasetError(f"{where} has no row of {m} on {rel} ({region}) though "
                                       f"run.json lists the pair; {fix}")
    return rows


#: The columns a comparison reads (results.csv holds them all: synth.validate.run.COLUMNS).
_READ_COLUMNS = ("matcher", "axis", "value", "seed", "region", "bad_2", "error", "sample")


def _real_specs(folder: Path, pairs: dict) -> tuple[str, ...]:
    """The ``--real`` SPECs of a run, in order, from its real pair folders' ``sample.json``."""
    specs: dict[str, None] = {}
    for rel in pairs:
        if rel.startswith("pairs/real/"):
            record = json.loads((folder / rel / "sample.json").read_bytes())
            specs[str(record["source"])] = None
    return tuple(specs)


def baseline_label(run: FinishedRun) -> str:
    """How the baseline's matcher is named beside the references: ``baseline ct:9``."""
    return f"baseline {run.matcher}"


def _same_names(where: str, what: str, theirs: Sequence[str], ours: Sequence[str],
                fix: str) -> None:
    """Refuse two runs whose ``what`` (axes, real scenes) differ, naming each side's own."""
    if set(theirs) == set(ours):
        return
    only = [", ".join(x for x in a if x not in b) or "none" for a, b in ((theirs, ours),
                                                                         (ours, theirs))]
    raise DatasetError(f"{where}: other {what}: only in the baseline: {only[0]}; only in this "
                       f"run: {only[1]}; {fix}")


def check_same_pairs(base: FinishedRun, *, suite: str, axes: Sequence[str],
                     real: Sequence[str], pairs: dict[str, str], folder: Path,
                     what: str = "--baseline") -> None:
    """Refuse (:class:`DatasetError`) unless ``base`` scored exactly these pairs.

    ``pairs`` maps this run's pair folders (relative to ``folder``) to their digests; a pair
    whose digest differs is compared file by file, and passes when only encodings differ.
    """
    from synth.dataset.compare import compare_datasets, same_content

    where = f"{what} {base.folder}"
    if base.suite != suite:
        raise DatasetError(f"{where}: made with --suite {base.suite}, this run uses --suite "
                           f"{suite}; compare runs of one suite")
    _same_names(where, "axes", base.axes, axes, f"pass --axes {','.join(base.axes)} to compare")
    _same_names(where, "real scenes", base.real, real,
                "leave out --real to take the baseline's"
                + (f" ({' '.join(base.real_specs)})" if base.real_specs else ""))
    for rel, digest in pairs.items():
        theirs = base.pairs.get(rel)
        if theirs is None:
            raise DatasetError(f"{where}: has no pair {rel}; it was made by another version "
                               "of stereoforge: validate the baseline matcher again")
        if theirs == digest:
            continue
        found = compare_datasets(base.folder / rel, folder / rel)
        if not same_content(found):
            first = min((d for d in found if d.kind not in ("encoding", "hashes")),
                        key=lambda d: (d.path.endswith(".json"), d.path))  # a file, not its hash
            raise DatasetError(f"{where}: pair {rel} is not the same: {first}; both runs must "
                               "score the same pairs: validate the baseline matcher again with "
                               "this version of stereoforge")


def _copy_tree(src: Path, dst: Path) -> None:
    """Copy folder ``src`` to ``dst`` through a temporary name (``dst`` appears whole)."""
    tmp = dst.parent / f".{dst.name}.tmp-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    dst.parent.mkdir(parents=True, exist_ok=True)
    try:
        shutil.copytree(src, tmp)
        shutil.rmtree(dst, ignore_errors=True)
        os.rename(tmp, dst)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def adopt_pairs(base: FinishedRun, missing: dict[int, object], out: Path) -> dict[int, dict]:
    """Copy into ``out`` each pair of ``missing`` (index: spec; pairs ``out`` lacks) that the
    baseline holds verified; ``{index: sample record}`` of the copies."""
    from synth.validate.pairs import verify_pair_folder

    adopted = {}
    for i, spec in missing.items():
        if verify_pair_folder(spec, base.folder):
            _copy_tree(base.folder / spec.folder, out / spec.folder)
            record = verify_pair_folder(spec, out)
            if record is not None:
                adopted[i] = record
    return adopted


def adopt_estimates(base: FinishedRun, references: Sequence[str], specs: Sequence,
                    out: Path, estimates: dict[str, str]) -> int:
    """Copy the baseline's estimate records (and PFMs) of each reference it also ran, for the
    pairs of ``specs``, where ``out`` has none; how many. ``estimates`` maps matchers to their
    folders in ``out`` (the run verifies each record before it uses it)."""
    from matcher.io import atomic_write_bytes

    copied = 0
    for ref in references:
        if ref not in base.estimates or ref not in estimates:
            continue
        for spec in specs:
            rel = spec.folder.removeprefix("pairs/")
            for suffix in (".json", ".pfm"):
                src = base.folder / base.estimates[ref] / f"{rel}{suffix}"
                dst = out / estimates[ref] / f"{rel}{suffix}"
                if src.is_file() and not dst.exists():
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    atomic_write_bytes(dst, src.read_bytes(), fsync=False)
                    copied += suffix == ".json"
    return copied


def compare_runs(baseline: str | Path, run: str | Path, out: str | Path
                 ) -> tuple[str, list[dict]]:
    """The report of finished run ``run`` against finished run ``baseline`` (old, then new),
    into ``out``: ``report.html`` and ``differences.csv``, nothing matched again. Returns the
    baseline's label and the difference table
    (:func:`synth.validate.differences.difference_table`)."""
    from matcher.io import atomic_write_bytes
    from synth.validate.differences import difference_table, differences_csv
    from synth.validate.pairs import folder_digest
    from synth.validate.report import write_report

    base = load_run(baseline, what="--compare")
    new = load_run(run, what="--compare")
    for r in (base, new):
        for rel in r.pairs:
            if folder_digest(r.folder / rel) is None:
                raise DatasetError(f"--compare {r.folder}: pair {rel} is missing or damaged (a "
                                   "file does not match its files.json); run `stereoforge "
                                   f"validate` into {r.folder} again to repair it")
    check_same_pairs(base, suite=new.suite, axes=new.axes, real=new.real, pairs=new.pairs,
                     folder=new.folder, what="--compare")
    label = baseline_label(base)
    rows = new.rows + base.rows_of(base.matcher, label=label)
    table = difference_table(rows, new.matcher, [label, *new.references])
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(out / "differences.csv", differences_csv(table), fsync=False)
    write_report(out, matcher=new.matcher, references=list(new.references), rows=rows,
                 source=new.folder, baseline=(label, base.folder))
    return label, table
