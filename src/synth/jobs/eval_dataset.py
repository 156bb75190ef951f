"""``stereoforge eval-dataset``: score any matcher on a dataset folder or a study's kept pairs.

The pairs are read through the dataset's manifest (:func:`synth.dataset.manifest.read_manifest`:
every ``MiddEval3/trainingF/NNNNNN/sample.json``), so a folder of ``stereoforge dataset --format middlebury`` and the
``pairs/`` folder of ``stereoforge study --keep-pairs`` (or the study folder itself) both work.
Each sample folder is a MiddEval3 scene (``im0.png``, ``im1.png``, ``disp0GT.pfm``,
``mask0nocc.png``). Regions: the ``mask_<region>.png`` files where present (validate's pairs),
else ``all``, ``nonocc`` and ``occluded`` from ``mask0nocc.png``. ``max_disparity`` per sample:
the option if given, else the sample's ``params.max_disparity`` (a study's), else ``calib.txt``'s
``ndisp``.

Outputs in ``out`` (default ``DIR/eval/<matcher>-<hash8>``): ``NNNNNN.pfm`` estimates and
``results.csv`` (:data:`COLUMNS`); the scores are :func:`matcher.regions.region_scores`.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from stereoforge.errors import DatasetError

__all__ = ["COLUMNS", "eval_dataset"]

COLUMNS = ("matcher", "index", "dir", "region", "bad_0_5", "bad_1", "bad_2", "bad_4", "avgerr",
           "rms", "a50", "a90", "a99", "coverage", "pixels", "max_disparity", "seconds",
           "mpix_disp_per_s", "error", "estimate")


def _root(folder: Path) -> tuple[Path, list[dict]]:
    from synth.dataset.manifest import read_manifest

    for root in (folder, folder / "pairs"):
        if root.is_dir():
            records = read_manifest(root)
            if records:
                return root, records
    raise DatasetError(f"{folder}: no samples (MiddEval3/trainingF/NNNNNN/sample.json) here or under pairs/; pass a "
                       "dataset folder (stereoforge dataset --format middlebury) or a study "
                       "folder made with --keep-pairs")


def _cell(value: object) -> object:
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else value


def eval_dataset(folder: str | Path, *, matcher: str, out: str | Path | None = None,
                 max_disparity: int | None = None, timeout: float = 60.0) -> Path:
    """Run ``matcher`` on every sample of ``folder``; write and return ``out/results.csv``."""
    import hashlib

    from matcher.adapters import resolve_matcher
    from matcher.io import atomic_write_bytes, read_calib, read_image, read_pfm, write_pfm
    from matcher.regions import REGIONS, region_scores
    from synth.dataset.layout import sample_dir

    folder = Path(folder)
    m = resolve_matcher(matcher, timeout=timeout)  # a bad string fails first, touching nothing
    root, records = _root(folder)
    if out is None:
        slug = "".join(c if c.isalnum() else "_" for c in m.spec)[:40]
        out = folder / "eval" / f"{slug}-{hashlib.sha256(m.spec.encode()).hexdigest()[:8]}"
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    try:
        for rec in records:
            sample = sample_dir(root, "middlebury", rec["index"])
            try:
                left, right = read_image(sample / "im0.png"), read_image(sample / "im1.png")
                gt = read_pfm(sample / "disp0GT.pfm")
                occ = read_image(sample / "mask0nocc.png")
            except FileNotFoundError as exc:
                raise DatasetError(f"{sample}: {exc.filename} is missing; eval-dataset reads "
                                   "MiddEval3 sample folders (--format middlebury)") from None
            d = max_disparity or rec["params"].get("max_disparity") \
                or int(read_calib(sample / "calib.txt")["ndisp"])
            d = int(min(d, gt.shape[1] - 1))
            if (sample / "mask_all.png").is_file():
                masks = {n: read_image(sample / f"mask_{n}.png") > 0 for n in REGIONS}
            else:
                import numpy as np

                has = np.isfinite(gt) & (occ != 0)
                masks = {"all": has, "nonocc": has & (occ == 255), "occluded": has & (occ == 128)}
            outcome = m.run(left, right, max_disparity=d)
            estimate = ""
            if outcome.disparity is not None:
                estimate = f"{rec['dir']}.pfm"
                write_pfm(out / estimate, outcome.disparity)
            rate = (gt.size * d / outcome.seconds / 1e6
                    if outcome.error is None and outcome.seconds > 0 else None)
            for name, mask in masks.items():
                s = region_scores(outcome.disparity, gt, mask)
                writer.writerow([_cell(v) for v in (
                    m.spec, rec["index"], rec["dir"], name, *(s[k] for k in COLUMNS[4:14]),
                    int(mask.sum()), d, outcome.seconds, rate, outcome.error or "", estimate)])
    finally:
        m.close()
    return atomic_write_bytes(out / "results.csv", buf.getvalue().encode(), fsync=False)
