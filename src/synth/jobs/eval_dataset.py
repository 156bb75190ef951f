"""``stereoforge eval-dataset``: score any matcher on a dataset folder or a study's kept pairs.

The pairs are read through the dataset's manifest
(:func:`synth.dataset.storage.manifest.read_manifest`: every sample folder's ``sample.json``) and
each sample through its layout (:meth:`synth.formats.base.Layout.read`: images, ground truth,
occlusion mask), so a folder of ``stereoforge dataset`` of any format with sample folders (as its
``dataset.json`` says) and the ``pairs/`` folder of ``stereoforge study --keep-pairs`` (or the
study folder itself, MiddEval3 folders) all work. Regions: the ``mask_<region>.png`` files where
present (validate's pairs), else ``all``, ``nonocc`` and ``occluded`` from the occlusion mask (a
KITTI frame's occluded pixels are those with ``disp_occ_0`` but no ``disp_noc_0``; a layout
without a mask gets a left-right check of its ground truths). ``max_disparity`` per sample: the
option if given, else the sample's ``params.max_disparity`` (a study's), else ``calib.txt``'s
``ndisp`` (Middlebury), else the ground truth's largest value + 1 rounded up to a multiple of 16,
as the Middlebury writer's ``ndisp``.

Outputs in ``out`` (default ``DIR/eval/<matcher>-<hash8>``): ``NNNNNN.pfm`` estimates and
``results.csv`` (:data:`COLUMNS`); the scores are :func:`matcher.regions.region_scores`.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from stereoforge.errors import DatasetError
from synth.formats import DEFAULT_FORMAT

__all__ = ["COLUMNS", "eval_dataset"]

COLUMNS = ("matcher", "index", "dir", "region", "bad_0_5", "bad_1", "bad_2", "bad_4", "avgerr",
           "rms", "a50", "a90", "a99", "coverage", "pixels", "max_disparity", "seconds",
           "mpix_disp_per_s", "error", "estimate")


def _root(folder: Path) -> tuple[Path, list[dict]]:
    from synth.dataset.storage.manifest import read_manifest

    for root in (folder, folder / "pairs"):
        if root.is_dir():
            records = read_manifest(root)
            if records:
                return root, records
    raise DatasetError(f"{folder}: no samples (MiddEval3/trainingF/NNNNNN/sample.json, "
                       "2014/NNNNNN/sample.json or training/samples/NNNNNN/sample.json) here or "
                       "under pairs/; pass a "
                       "dataset folder (stereoforge dataset) or a study folder made with "
                       "--keep-pairs")


def _load(root: Path, fmt: str, rec: dict) -> tuple:
    """``(left, right, gt, occlusion mask, default max_disparity, region masks or None)`` of a
    sample, read through its layout (:meth:`synth.formats.base.Layout.read`); a missing file is
    a :exc:`DatasetError` naming it."""
    from synth.formats import get_layout
    from synth.formats.base import ndisp_for

    index = rec["index"]
    try:
        s = get_layout(fmt).read(root, index)
    except FileNotFoundError as exc:
        missing = (f"{exc.filename} is missing" if exc.filename is not None
                   else " ".join(str(exc).split()))
        raise DatasetError(f"{root}: sample {index}: {missing}; eval-dataset "
                           f"reads the {fmt} layout's files (see stereoforge dataset "
                           "--format)") from None
    default = s.meta["ndisp"] if "ndisp" in s.meta else ndisp_for(s.disp_left)
    return s.left, s.right, s.disp_left, s.mask_left, default, s.regions


def _cell(value: object) -> object:
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else value


def eval_dataset(folder: str | Path, *, matcher: str, out: str | Path | None = None,
                 max_disparity: int | None = None, timeout: float = 60.0) -> Path:
    """Run ``matcher`` on every sample of ``folder``; write and return ``out/results.csv``."""
    import hashlib

    from matcher.adapters import resolve_matcher
    from matcher.io import atomic_write_bytes, write_pfm
    from matcher.regions import region_scores
    from synth.dataset.storage.layout import dataset_format
    from synth.formats import FORMATS, get_layout

    folder = Path(folder)
    m = resolve_matcher(matcher, timeout=timeout)  # a bad string fails first, touching nothing
    try:
        root, records = _root(folder)
        # a dataset names its layout; a study's pairs are MiddEval3 folders
        fmt = dataset_format(root) if (root / "dataset.json").is_file() else DEFAULT_FORMAT
        if not get_layout(fmt).capacity.sample_folders:
            raise DatasetError(f"{root} is a {fmt} dataset (samples packed in tar shards); "
                               "eval-dataset reads sample folders: write the dataset with "
                               f"--format {', '.join(FORMATS)}")
    except BaseException:
        m.close()
        raise
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
            left, right, gt, occ, default, regions = _load(root, fmt, rec)
            d = max_disparity or rec["params"].get("max_disparity") or default
            d = int(min(d, gt.shape[1] - 1))
            if regions is not None:
                masks = regions
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
