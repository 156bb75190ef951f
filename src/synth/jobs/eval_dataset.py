"""``stereoforge eval-dataset``: score any matcher on a dataset folder or a study's kept pairs.

The pairs are read through the dataset's manifest
(:func:`synth.dataset.storage.manifest.read_manifest`: every
``MiddEval3/trainingF/NNNNNN/sample.json``, ``2014/NNNNNN/sample.json`` or
``training/samples/NNNNNN/sample.json``), so a folder of ``stereoforge dataset`` (``--format
middlebury``, ``middlebury2014`` or ``kitti``, as its ``dataset.json`` says) and the ``pairs/``
folder of ``stereoforge study --keep-pairs`` (or the study folder itself) all work. A Middlebury
sample folder is a MiddEval3 scene (``im0.png``, ``im1.png``, ``disp0GT.pfm``, ``mask0nocc.png``;
the ground truth is ``disp0.pfm`` in the 2014 layout); a KITTI sample is frame ``NNNNNN_10`` of
``training/`` (``image_2``, ``image_3``, ``disp_occ_0``, ``disp_noc_0``: the regions' occluded
pixels are those with ``disp_occ_0`` but no ``disp_noc_0``). Regions: the ``mask_<region>.png``
files where present (validate's pairs), else ``all``, ``nonocc`` and ``occluded``. ``max_disparity``
per sample: the option if given, else the sample's ``params.max_disparity`` (a study's), else
``calib.txt``'s ``ndisp`` (Middlebury), else (KITTI) the ground truth's largest value + 1 rounded up
to a multiple of 16, as the Middlebury writer's ``ndisp``.

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
    """``(left, right, gt, occlusion mask, default max_disparity (a callable: calib.txt is read
    only when needed), region mask folder or None)`` of a sample; a missing file is a
    :exc:`DatasetError` naming it."""
    import math

    import numpy as np

    from matcher.io import GT_FILES, load_kitti_2015, read_calib, read_image, read_pfm
    from synth.dataset.storage.layout import sample_dir
    from synth.write.formats import KITTI_ROOT, MIDDLEBURY_LAYOUTS

    index = rec["index"]
    try:
        if fmt == "kitti":
            s = load_kitti_2015(root / KITTI_ROOT, index)
            finite = s.disp_left[np.isfinite(s.disp_left)]
            vmax = math.ceil(float(finite.max())) if finite.size else 0
            occ = s.mask_left if s.mask_left is not None else np.where(
                np.isfinite(s.disp_left), 255, 0).astype(np.uint8)
            return s.left, s.right, s.disp_left, occ, lambda: 16 * math.ceil((vmax + 1) / 16), None
        sample = sample_dir(root, fmt, index)
        left, right = read_image(sample / "im0.png"), read_image(sample / "im1.png")
        gt = read_pfm(sample / GT_FILES[MIDDLEBURY_LAYOUTS[fmt]][0])
        occ = read_image(sample / "mask0nocc.png")
        return left, right, gt, occ, lambda: int(read_calib(sample / "calib.txt")["ndisp"]), sample
    except FileNotFoundError as exc:
        raise DatasetError(f"{root}: sample {index}: {exc.filename} is missing; eval-dataset "
                           f"reads the {fmt} layout's files (see stereoforge dataset "
                           "--format)") from None


def _cell(value: object) -> object:
    if value is None:
        return ""
    return repr(value) if isinstance(value, float) else value


def eval_dataset(folder: str | Path, *, matcher: str, out: str | Path | None = None,
                 max_disparity: int | None = None, timeout: float = 60.0) -> Path:
    """Run ``matcher`` on every sample of ``folder``; write and return ``out/results.csv``."""
    import hashlib

    from matcher.adapters import resolve_matcher
    from matcher.io import atomic_write_bytes, read_image, write_pfm
    from matcher.regions import REGIONS, region_scores
    from synth.dataset.storage.layout import dataset_format
    from synth.write.formats import FORMATS

    folder = Path(folder)
    m = resolve_matcher(matcher, timeout=timeout)  # a bad string fails first, touching nothing
    try:
        root, records = _root(folder)
        # a dataset names its layout; a study's pairs are MiddEval3 folders
        fmt = dataset_format(root) if (root / "dataset.json").is_file() else "middlebury"
        if fmt not in FORMATS:
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
            left, right, gt, occ, default, sample = _load(root, fmt, rec)
            d = max_disparity or rec["params"].get("max_disparity") or default()
            d = int(min(d, gt.shape[1] - 1))
            if sample is not None and (sample / "mask_all.png").is_file():
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
