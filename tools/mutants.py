#!/usr/bin/env python3
"""Mutation check: plant deliberate bugs in the matcher and show which tests kill each one.

Each mutant is one textual change to one source file. For every mutant the script copies ``src/``,
``tests/``, ``conftest.py`` and ``pyproject.toml`` into a temporary folder, applies the change,
runs the matcher tests there (the copy's ``src`` first on ``PYTHONPATH``) and records the tests
that fail. A mutant survives when no test fails: that is a hole in the suite. The script exits 1
if any mutant survives (or cannot be planted because its target text moved), so it can guard the
suite itself.

Usage::

    .venv/bin/python tools/mutants.py              # all mutants, Markdown table on stdout
    .venv/bin/python tools/mutants.py --list       # what would be planted
    .venv/bin/python tools/mutants.py -k spiral    # only mutants whose name contains "spiral"

It takes a few minutes (each mutant recompiles the numba kernels); it does not run in CI.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    name: str
    path: str  # relative to the repository root
    edits: tuple[tuple[str, str], ...]  # (exact old text, new text); each old text must occur
    why: str


_U8_BITS = tuple((f"if c > s{k}[x]", f"if c < s{k}[x]") for k in range(8))
_U8_BITS_GE = tuple((f"if c > s{k}[x]", f"if c >= s{k}[x]") for k in range(8))

MUTANTS = (
    Mutant(
        "census comparison flipped",
        "src/matcher/_kernels/census.py",
        (*_U8_BITS, ("centre[x] > src[x]", "centre[x] < src[x]")),
        "bit = I(p) < I(p') instead of the paper's I(p) > I(p') (Eq. 2)",
    ),
    Mutant(
        "census comparison not strict",
        "src/matcher/_kernels/census.py",
        (*_U8_BITS_GE, ("centre[x] > src[x]", "centre[x] >= src[x]")),
        "ties I(p) == I(p') set the bit",
    ),
    Mutant(
        "spiral order broken (rings start downwards)",
        "src/matcher/patterns.py",
        (("out += [(-k, r) for k in range(0, r + 1)]", "out += [(k, r) for k in range(0, r + 1)]"),),
        "each ring runs clockwise from its start instead of counter-clockwise (Fig. 5)",
    ),
    Mutant(
        "disparity off by one",
        "src/matcher/_kernels/census.py",
        (("val = np.float64(d)", "val = np.float64(d + 1)"),),
        "the winner-takes-all result of CT/SCT is d + 1",
    ),
    Mutant(
        "ties go to the largest d",
        "src/matcher/_kernels/census.py",
        (("if c[i] < bc[i]:", "if c[i] <= bc[i]:"),),
        "winner-takes-all keeps the last minimum instead of the first",
    ),
    Mutant(
        "invalid pixels counted as good",
        "src/matcher/metrics.py",
        (("return 100.0 * (int((err > threshold).sum()) + (n - err.size)) / n",
          "return 100.0 * int((err > threshold).sum()) / n"),),
        "PoBMP and bad-x forget the invalid estimates",
    ),
    Mutant(
        "N miscounted (one decrease too few)",
        "src/matcher/_kernels/adaptive.py",
        (("if rn == n_decreases and", "if rn == n_decreases - 1 and"),),
        "AWCT stops after N - 1 consecutive decreases of the edge proportion",
    ),
    Mutant(
        "AWCT ignores the smaller window",
        "src/matcher/_kernels/adaptive.py",
        (("            if b >= total_bits:\n                continue",
          "            if b >= 0:\n                continue"),),
        "pixels with a small window are scored over the largest window's code, not their prefix",
    ),
)


def _copy_tree(dst: Path) -> None:
    for name in ("src", "tests"):
        shutil.copytree(ROOT / name, dst / name,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "*.nbi", "*.nbc"))
    for name in ("conftest.py", "pyproject.toml"):
        shutil.copy2(ROOT / name, dst / name)


def _plant(work: Path, mutant: Mutant) -> str:
    path = work / mutant.path
    text = path.read_text()
    for old, new in mutant.edits:
        if old not in text:
            raise LookupError(f"{mutant.path}: target text not found (did the code move?): {old!r}")
        text = text.replace(old, new)
    path.write_text(text)
    old, new = (" ".join(t.split()) for t in mutant.edits[-1])  # one line for the table
    more = f" (+{len(mutant.edits) - 1} alike)" if len(mutant.edits) > 1 else ""
    return f"{old} -> {new}{more}"


def _failed_tests(junit: Path) -> list[str]:
    failed = []
    for case in ET.parse(junit).getroot().iter("testcase"):
        if case.find("failure") is not None or case.find("error") is not None:
            failed.append(f"{case.get('classname', '')}::{case.get('name', '')}")
    return failed


def run_mutant(mutant: Mutant, *, test_paths: list[str], python: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="sf-mutant-") as tmp:
        work = Path(tmp)
        _copy_tree(work)
        try:
            change = _plant(work, mutant)
        except LookupError as exc:
            return {"mutant": mutant, "change": str(exc), "killed_by": [], "seconds": 0.0}
        env = dict(os.environ, PYTHONPATH=str(work / "src"), HYPOTHESIS_PROFILE="ci",
                   NUMBA_CACHE_DIR=str(work / ".numba"))
        # make sure the copy (not the installed tree) is what gets imported
        where = subprocess.run([python, "-c", "import matcher; print(matcher.__file__)"],
                               cwd=work, env=env, capture_output=True, text=True)
        if not where.stdout.strip().startswith(str(work)):
            raise RuntimeError(f"mutant not imported from the copy: {where.stdout}{where.stderr}")
        junit = work / "junit.xml"
        t0 = time.perf_counter()
        subprocess.run(
            [python, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={junit}",
             "--hypothesis-profile=ci", *test_paths],
            cwd=work, env=env, capture_output=True, text=True,
        )
        seconds = time.perf_counter() - t0
        killed = _failed_tests(junit) if junit.exists() else ["<pytest crashed>"]
        return {"mutant": mutant, "change": change, "killed_by": killed, "seconds": seconds}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("-k", default="", help="only mutants whose name contains this text")
    parser.add_argument("--list", action="store_true", help="list the mutants and exit")
    parser.add_argument("--tests", nargs="*", default=["tests/matcher", "src/matcher"],
                        help="test paths run against each mutant (default: the matcher tests)")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTANTS if args.k in m.name]
    if args.list:
        for m in chosen:
            print(f"- {m.name} ({m.path}): {m.why}")
        return 0
    python = sys.executable
    rows = []
    for m in chosen:
        print(f"planting: {m.name} ...", file=sys.stderr, flush=True)
        rows.append(run_mutant(m, test_paths=args.tests, python=python))
    print("| mutant | file | change | killed | tests that kill it | s |")
    print("|---|---|---|---|---|---|")
    survivors = 0
    for r in rows:
        m, killed = r["mutant"], r["killed_by"]
        ok = bool(killed)
        survivors += not ok
        distinct = sorted({k.split("::")[-1].split("[")[0] for k in killed})
        names = ", ".join(distinct[:5]) if killed else "-"
        extra = f" (+{len(distinct) - 5} more)" if len(distinct) > 5 else ""
        print(f"| {m.name} | {m.path} | `{r['change']}` | {'yes' if ok else '**NO**'} "
              f"({len(killed or [])}) | {names}{extra} | {r['seconds']:.0f} |")
    print(f"\n{len(rows) - survivors}/{len(rows)} mutants killed")
    return 1 if survivors else 0


if __name__ == "__main__":
    sys.exit(main())
