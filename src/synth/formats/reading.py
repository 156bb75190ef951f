"""What every sample read from a tree must be, whatever its layout: its arrays checked to agree
(:func:`checked_sample`), a reader's raw error on damaged files as one
:class:`~stereoforge.errors.FormatError` (:func:`damage_as_format_error`), the occlusion mask
filled where a layout has none (:func:`fill_occlusion`), and the calibration of the records
that hold it (``scene.json``'s rig, Middlebury's ``calib.txt``)."""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from matcher.io import StereoSample

__all__ = ["calib_from_middlebury", "calib_from_rig", "checked_sample", "damage_as_format_error",
           "fill_occlusion", "rig_record"]


@contextlib.contextmanager
def damage_as_format_error(where: str) -> Iterator[None]:
    """Inside the block, what a reader raises on damaged files (a raw ``ValueError``,
    ``KeyError``, ``IndexError`` or ``TypeError`` of a decoder) becomes a
    :class:`~stereoforge.errors.FormatError` naming ``where``; stereoforge's own errors and
    ``FileNotFoundError`` pass as they are."""
    from stereoforge.errors import FormatError, StereoforgeError

    try:
        yield
    except StereoforgeError:
        raise
    except (ValueError, KeyError, IndexError, TypeError) as exc:
        text = " ".join(str(exc).split()) or type(exc).__name__
        raise FormatError(f"{where}: {text}") from None


def checked_sample(sample: StereoSample, where: str) -> StereoSample:
    """``sample`` with its views as RGB (a grey view's channel repeated), once its arrays agree:
    two views of one size, one-channel float disparities, a one-channel mask, the flow and the
    regions of that size.

    Raises
    ------
    FormatError
        An array of another size or kind; the message names it, ``where`` (the sample) and
        both shapes.
    """
    from stereoforge.errors import FormatError

    files = sample.meta.get("files") if isinstance(sample.meta.get("files"), dict) else {}

    def named(name: str) -> str:
        return f"{name} ({files[name]})" if name in files else name

    views = []
    for name, view in (("left view", sample.left), ("right view", sample.right)):
        if not isinstance(view, np.ndarray) or view.dtype != np.uint8 or not (
                view.ndim == 2 or (view.ndim == 3 and view.shape[2] in (1, 3))):
            got = (f"{view.dtype} {view.shape}" if isinstance(view, np.ndarray)
                   else type(view).__name__)
            raise FormatError(f"{where}: the {named(name)} is {got}; a view is an 8-bit grey or "
                              "RGB image")
        views.append(np.repeat(view.reshape(*view.shape[:2], 1), 3, axis=2)
                     if view.ndim == 2 or view.shape[2] == 1 else view)
    size = views[0].shape[:2]

    def agree(name: str, array: np.ndarray | None, ndim: int, kind: str) -> None:
        if array is None:
            return
        if not isinstance(array, np.ndarray) or array.ndim != ndim or array.shape[:2] != size:
            shape = array.shape if isinstance(array, np.ndarray) else type(array).__name__
            raise FormatError(f"{where}: the {named(name)} is {shape}, the left view {size}: a "
                              f"sample's {kind} must be one size")
    agree("right view", views[1], 3, "images, ground truth and masks")
    for name, array in (("left disparity", sample.disp_left),
                        ("right disparity", sample.disp_right)):
        if isinstance(array, np.ndarray) and array.ndim == 3:
            raise FormatError(f"{where}: the {named(name)} has {array.shape[2]} channels "
                              f"{array.shape}; a disparity map has one")
        agree(name, array, 2, "images, ground truth and masks")
    agree("occlusion mask", sample.mask_left, 2, "images, ground truth and masks")
    agree("flow", sample.flow_left, 3, "images, ground truth and masks")
    for region, mask in (sample.regions or {}).items():
        agree(f"region mask {region!r}", mask, 2, "images, ground truth and masks")
    if views[0] is sample.left and views[1] is sample.right:
        return sample
    return dataclasses.replace(sample, left=views[0], right=views[1])


def rig_record(rig: dict[str, Any], path: Path) -> dict[str, Any]:
    """A ``scene.json`` rig record with the calibration keys, as numbers."""
    from stereoforge.errors import DatasetError

    bad = [k for k in ("fx", "fy", "cx", "cy", "baseline")
           if isinstance(rig.get(k), bool) or not isinstance(rig.get(k), (int, float))]
    if bad:
        raise DatasetError(f"{path}: the rig has no number {bad[0]!r}; the dataset was "
                           "modified: render the sample again")
    return rig


def calib_from_rig(rig: dict[str, Any]) -> dict[str, float]:
    """``fx, fy, cx, cy`` (pixels) and ``baseline`` (metres) of a ``scene.json`` rig record."""
    return {k: float(rig[k]) for k in ("fx", "fy", "cx", "cy", "baseline")}


def calib_from_middlebury(calib: dict | None) -> dict[str, float] | None:
    """``fx, fy, cx, cy`` (pixels) and ``baseline`` (metres) of a parsed Middlebury
    ``calib.txt`` (:func:`matcher.io.read_calib`: ``cam0``, ``baseline`` in mm), or None."""
    if not calib or "cam0" not in calib or "baseline" not in calib:
        return None
    cam0 = np.asarray(calib["cam0"], dtype=np.float64)
    return {"fx": float(cam0[0, 0]), "fy": float(cam0[1, 1]), "cx": float(cam0[0, 2]),
            "cy": float(cam0[1, 2]), "baseline": float(calib["baseline"]) / 1000.0}


def fill_occlusion(sample: StereoSample) -> tuple[np.ndarray, str]:
    """The occlusion mask of a sample (255 visible in both views, 128 occluded, 0 no ground
    truth) and how it was made: its own mask, else a left-right check of its ground truths
    (:func:`matcher.regions.occlusion_from_disparities`; the left one warped to the right view
    when there is no right one)."""
    from matcher.regions import occlusion_from_disparities

    gt = sample.disp_left
    if sample.mask_left is not None:
        return (np.where(np.isfinite(gt), sample.mask_left, 0).astype(np.uint8),
                "the scene's own occlusion mask")
    if sample.disp_right is not None:
        return (occlusion_from_disparities(gt, sample.disp_right),
                "left-right check of the left and right ground truths")
    return (occlusion_from_disparities(gt),
            "left-right check: the left ground truth warped to the right view")
