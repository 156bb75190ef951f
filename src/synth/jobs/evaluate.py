"""Evaluate disparity files against ground-truth files (the library side of ``stereoforge eval``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from matcher.io import read_disparity, read_image
from matcher.metrics import evaluate

__all__ = ["evaluate_files"]


def evaluate_files(
    disp: str | Path,
    gt: str | Path,
    *,
    gt_divisor: float | None = None,
    disp_divisor: float | None = None,
    mask: str | Path | None = None,
    delta: float = 3.0,
) -> dict[str, dict]:
    """Metrics of the disparity file ``disp`` against ``gt``, per region.

    Parameters
    ----------
    disp, gt : str or Path
        PFM (``inf`` = invalid / no ground truth) or PNG (8-bit with a divisor, 0 = unknown;
        16-bit KITTI, value / 256).
    gt_divisor, disp_divisor : float, optional
        Divisor of an 8-bit PNG.
    mask : str or Path, optional
        Occlusion mask PNG (255 = visible in both views); adds the ``nonocc`` region.
    delta : float
        PoBMP threshold in pixels.

    Returns
    -------
    dict
        ``{"all": {...}}`` and, with a mask, ``{"nonocc": {...}}``: the fields of
        :class:`matcher.metrics.Metrics`.
    """
    estimate = read_disparity(disp, divisor=disp_divisor)
    truth = read_disparity(gt, divisor=gt_divisor)
    report = {"all": dataclasses.asdict(evaluate(estimate, truth, delta=delta))}
    if mask is not None:
        occ = read_image(mask)
        if occ.ndim == 3:
            occ = occ[..., 0]
        report["nonocc"] = dataclasses.asdict(
            evaluate(estimate, truth, delta=delta, region="nonocc", occlusion_mask=occ)
        )
    return report
