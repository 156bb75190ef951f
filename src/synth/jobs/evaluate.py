"""Evaluate disparity files against ground-truth files (the library side of ``stereoforge eval``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from matcher.io import read_disparity, read_grey_image
from matcher import eth3d_two_view, evaluate, kitti_2015, middlebury_v3

__all__ = ["BENCHMARKS", "CONVENTIONS", "evaluate_benchmarks", "evaluate_files"]

#: ``--benchmark`` choices.
BENCHMARKS = ("middlebury", "kitti", "eth3d")
#: What each figure follows, printed beside it by ``stereoforge eval``.
CONVENTIONS = {
    "middlebury": "MiddEval3 SDK 1.6 evaldisp: bad excludes holes, totbad = bad + invalid, "
                  "avgerr/rms/A* over valid estimates, clipped to [0, ndisp]",
    "kitti": "KITTI 2015 devkit: holes interpolated (interpolateBackground) first; D1 = > 3 px "
             "and > 5 %; *_est over estimated pixels only; density in %",
    "eth3d": "ETH3D two-view: bad/avgerr/rms/A* over estimated pixels; coverage = estimated %",
}


#: What a colour mask or object map should be instead (stereoforge eval --mask, --obj-map).
_MASK_FIX = ("save it as a grey PNG: 255 visible in both views, 128 occluded, 0 no ground truth "
             "(mask0nocc.png)")
_OBJ_MAP_FIX = "save it as a grey PNG: 0 background, 1..255 objects (KITTI's obj_map)"


def _mask(path: str | Path):
    return read_grey_image(path, what="mask", fix=_MASK_FIX)


def evaluate_benchmarks(
    disp: str | Path,
    gt: str | Path,
    *,
    benchmarks: tuple[str, ...] = BENCHMARKS,
    gt_divisor: float | None = None,
    disp_divisor: float | None = None,
    mask: str | Path | None = None,
    obj_map: str | Path | None = None,
    ndisp: int | None = None,
    isint: bool = False,
) -> dict[str, dict]:
    """Metrics of ``disp`` against ``gt`` as each benchmark's own code defines them.

    Returns
    -------
    dict
        ``{"<benchmark> <region>": {"convention": ..., <fields>}}``; ``nonocc``/``noc`` regions
        need ``mask`` (255 = visible in both views); KITTI's bg/fg split needs ``obj_map``.
    """
    for name in benchmarks:
        if name not in BENCHMARKS:
            raise ValueError(f"--benchmark: expected one of {', '.join(BENCHMARKS)}, got {name!r}")
    estimate = read_disparity(disp, divisor=disp_divisor)
    truth = read_disparity(gt, divisor=gt_divisor)
    occ = None if mask is None else _mask(mask)
    regions = ("all",) if occ is None else ("all", "nonocc")
    objects = None if obj_map is None else read_grey_image(obj_map, what="obj_map",
                                                            fix=_OBJ_MAP_FIX)
    report: dict[str, dict] = {}
    for name in benchmarks:
        note = {"convention": CONVENTIONS[name]}
        for key, fields in _REPORTS[name](estimate, truth, occ, regions, objects, ndisp, isint):
            report[key] = note | fields
    return report


def _middlebury(estimate, truth, occ, regions, objects, ndisp, isint) -> list[tuple[str, dict]]:
    return [(f"middlebury {region}", dataclasses.asdict(middlebury_v3(
        estimate, truth, occlusion_mask=occ, region=region, maxdisp=ndisp, rounddisp=isint)))
        for region in regions]


def _eth3d(estimate, truth, occ, regions, objects, ndisp, isint) -> list[tuple[str, dict]]:
    return [(f"eth3d {region}", dataclasses.asdict(eth3d_two_view(
        estimate, truth, occlusion_mask=occ, region=region))) for region in regions]


def _kitti(estimate, truth, occ, regions, objects, ndisp, isint) -> list[tuple[str, dict]]:
    k = kitti_2015(estimate, truth, occlusion_mask=occ, obj_map=objects)
    out = [("kitti occ", dataclasses.asdict(k.occ))]
    if k.noc is not None:
        out.append(("kitti noc", dataclasses.asdict(k.noc)))
    return out


#: Each benchmark's figures (``stereoforge eval --benchmark``), as its own code defines them.
_REPORTS = {"middlebury": _middlebury, "kitti": _kitti, "eth3d": _eth3d}


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
        Occlusion mask PNG, grey (255 = visible in both views; a colour PNG is refused unless
        its channels are equal); adds the ``nonocc`` region.
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
        report["nonocc"] = dataclasses.asdict(
            evaluate(estimate, truth, delta=delta, region="nonocc", occlusion_mask=_mask(mask))
        )
    return report
