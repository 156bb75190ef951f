"""``stereoforge bench validate``: wall time of a whole ``validate`` run from an empty folder.

The issue's target: ``--suite quick`` within 2 minutes on a 2-core machine for a matcher as fast
as CT-9 at 320 x 240. Each repeat runs :func:`synth.validate.run.run_validate` into a fresh
temporary folder (nothing reused), and the table gives each stage's seconds.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Sequence

__all__ = ["bench_validate"]


def bench_validate(*, matcher: str = "ct:9", suite: str = "quick",
                   against: Sequence[str] = ("ct:9", "sgbm:5"), workers: Sequence[int] = (1, 2),
                   repeats: int = 1, backend: str = "auto", battery: bool = True,
                   progress: bool = False) -> list[dict]:
    """One row per worker count and repeat: pairs, seconds per stage, total, target."""
    from synth.validate.run import plan, run_validate

    rows = []
    for k in workers:
        for repeat in range(repeats):
            tmp = Path(tempfile.mkdtemp(prefix="stereoforge-bench-validate-"))
            try:
                res = run_validate(matcher, out=tmp, suite=suite, against=against, workers=k,
                                   backend=backend, progress=progress, battery=battery)
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
            s = res.seconds
            rows.append({"matcher": matcher, "suite": suite, "against": ",".join(against),
                         "workers": k, "repeat": repeat, "pairs": len(plan(suite)),
                         "estimates": res.estimates_computed,
                         "pairs_s": round(s["pairs"], 2), "matching_s": round(s["matching"], 2),
                         "battery_report_s": round(s["battery"], 2) if battery else None,
                         "total_s": round(s["total"], 2),
                         "target_s": 120 if suite == "quick" else None})
    return rows
