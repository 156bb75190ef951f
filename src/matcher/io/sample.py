"""A stereo sample in memory (:class:`StereoSample`, what the dataset readers return) and the
checks the Middlebury and KITTI readers and writers share."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["StereoSample", "check_sample_shapes", "check_stereo_images", "require_dir"]


@dataclass(frozen=True, eq=False)
class StereoSample:
    """A rectified stereo pair with ground truth.

    Attributes
    ----------
    left, right : (H, W, 3) uint8 array
        RGB images (``(H, W)`` for grey files).
    disp_left : (H, W) float32 array
        Left ground-truth disparity in pixels, ``inf`` where unknown.
    disp_right : (H, W) float32 array or None
        Right ground truth, when the dataset provides it.
    name : str
        Scene name or frame id.
    meta : dict
        Dataset-specific information (``dataset``, ``divisor``, ``calib``, paths ...).
    mask_left : (H, W) uint8 array or None
        Occlusion mask of the left view (255 visible in both, 128 occluded, 0 no ground truth),
        when the dataset provides one.
    calib : dict or None
        ``fx``, ``fy``, ``cx``, ``cy`` (pixels) and ``baseline`` (metres), when known.
    flow_left : (H, W, 2) float32 array or None
        The exact 2-D flow of the left view to the right one (a rig with camera errors), NaN
        where unknown, when the dataset holds it.
    regions : dict of str to (H, W) bool array, or None
        Named pixel regions of the left view (validate's ``mask_<region>.png``), when stored.
    extras : dict of str to array
        Further ground truth stored beside the sample (depth, normals, ...: the reading
        layout's), by kind.
    """

    left: np.ndarray
    right: np.ndarray
    disp_left: np.ndarray
    disp_right: np.ndarray | None
    name: str
    meta: dict = field(default_factory=dict)
    mask_left: np.ndarray | None = None
    calib: dict | None = None
    flow_left: np.ndarray | None = None
    regions: dict | None = None
    extras: dict = field(default_factory=dict)


def require_dir(path: Path, what: str) -> None:
    """Raise :class:`FileNotFoundError` naming ``what`` unless ``path`` is a directory."""
    if not path.is_dir():
        raise FileNotFoundError(f"{what}: {path} is not a directory")


def check_sample_shapes(
    sample_dir: Path, left: np.ndarray, right: np.ndarray, *disps: np.ndarray | None
) -> None:
    """Raise :class:`ValueError` unless every array read from ``sample_dir`` (None: absent) has
    the left image's height and width."""
    for array in (right, *disps):
        if array is not None and array.shape[:2] != left.shape[:2]:
            raise ValueError(
                f"{sample_dir}: image/disparity sizes differ: {left.shape[:2]} vs {array.shape[:2]}"
            )


def check_stereo_images(left: object, right: object) -> tuple[np.ndarray, np.ndarray]:
    """Validate a pair of images to write: uint8, ``(H, W)`` or ``(H, W, 3)``, same shape.

    Examples
    --------
    >>> import numpy as np
    >>> check_stereo_images(np.zeros((2, 2), np.uint8), np.zeros((2, 2), np.uint8))[0].shape
    (2, 2)
    """
    for name, image in (("left", left), ("right", right)):
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8:
            got = f"dtype {image.dtype}" if isinstance(image, np.ndarray) else type(image).__name__
            raise TypeError(f"{name}: expected a uint8 image, got {got}; convert with np.clip(...).astype(np.uint8)")
        if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)) or 0 in image.shape:
            raise ValueError(f"{name}: expected shape (H, W) or (H, W, 3) (RGB), got {image.shape}")
    if left.shape != right.shape:  # type: ignore[union-attr]
        raise ValueError(f"left and right: expected the same shape, got {left.shape} and {right.shape}")  # type: ignore[union-attr]
    return left, right  # type: ignore[return-value]
