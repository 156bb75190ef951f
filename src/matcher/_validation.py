"""Validation helpers shared by the public functions of :mod:`matcher`.

Every public function validates its input once, here, and raises
:class:`~stereoforge.errors.ParameterError` (a ``ValueError``) or
:class:`~stereoforge.errors.ParameterTypeError` (a ``TypeError``) that names the parameter, the
expected and the actual value, and the fix. Kernels downstream trust what these helpers return.

The array checks of stereo matching (images, disparity maps, masks, windows) live here, built
on :mod:`stereoforge.validation`, whose scalar checks (:func:`check_bool`, :func:`check_int`,
:func:`check_real`, :func:`check_choice`) this module re-exports: matcher code imports its checks
from here. Other modules may append helpers; keep each one small and build its message with
:func:`stereoforge.validation.fail`: ``"<name>: expected <what>, got <actual>; <fix>"``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from stereoforge.validation import (
    check_array,
    check_bool,
    check_choice,
    check_dtype,
    check_finite,
    check_int,
    check_real,
    check_shape,
    check_type,
    fail,
)

__all__ = [
    "GREY_WEIGHTS",
    "MASK_CODES",
    "check_bool",
    "check_choice",
    "check_int",
    "check_real",
    "check_ground_truth",
    "check_occlusion_mask",
    "check_disparity_map",
    "check_image",
    "check_max_disparity",
    "check_positive",
    "check_same_shape",
    "check_window",
    "rgb_to_grey",
]

#: ITU-R BT.601 luma weights for (R, G, B), the ones OpenCV's ``COLOR_RGB2GRAY`` uses.
GREY_WEIGHTS: tuple[float, float, float] = (0.299, 0.587, 0.114)


def rgb_to_grey(image: np.ndarray) -> np.ndarray:
    """Convert an ``(H, W, 3)`` RGB array to grey with :data:`GREY_WEIGHTS`.

    ``uint8`` input gives ``uint8`` output (rounded half up, clipped to 0..255, like OpenCV);
    float input gives output of the same float dtype; other integer input gives ``float64``.
    Input is trusted (no validation): use :func:`check_image` at a public boundary.
    """
    w = np.asarray(GREY_WEIGHTS, dtype=np.float64)
    if image.dtype == np.uint8:  # float64 weighted sum, rounded half up (see the kernel)
        from matcher._kernels.grey import grey_uint8_kernel

        out = np.empty(image.shape[:2], np.uint8)
        grey_uint8_kernel(np.ascontiguousarray(image), out)
        return out
    if image.dtype.kind == "f":
        return (image @ w.astype(image.dtype)).astype(image.dtype, copy=False)
    return image.astype(np.float64) @ w


def check_image(image: object, name: str) -> np.ndarray:
    """Validate an image and return it as a 2-D grey array.

    Parameters
    ----------
    image : (H, W), (H, W, 1) or (H, W, 3) array
        Grey or RGB (channel order R, G, B) image. ``uint8``, other unsigned/signed integers
        and ``float32``/``float64`` are accepted; ``bool`` and complex are not.
    name : str
        Parameter name used in error messages.

    Returns
    -------
    (H, W) uint8 or float array
        ``uint8`` stays ``uint8``; floats keep their dtype; other integers become ``float64``.
        RGB is converted with :data:`GREY_WEIGHTS` (see :func:`rgb_to_grey`).

    Raises
    ------
    TypeError
        If ``image`` is not an array of a supported dtype.
    ValueError
        If the shape is wrong, the image is empty, or a float image holds NaN or inf.

    Examples
    --------
    >>> import numpy as np
    >>> check_image(np.zeros((2, 3, 3), np.uint8), "left").shape
    (2, 3)
    """
    check_array(image, name)
    check_dtype(image, name, kinds="uif", expected="a uint8, integer or float image",
                fix="convert with .astype(np.uint8) or .astype(np.float32)")
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise fail(name, "shape (H, W), (H, W, 1) or (H, W, 3) (RGB)", str(image.shape),
                   fix="drop an alpha channel with image[..., :3]")
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise fail(name, "a non-empty image", f"shape {image.shape}")
    if image.dtype.kind == "f":
        check_finite(image, name, what="pixel values",
                     fix="replace them (e.g. np.nan_to_num) before matching")
    if image.ndim == 3:
        return rgb_to_grey(image)
    if image.dtype == np.uint8 or image.dtype.kind == "f":
        return image
    return image.astype(np.float64)


def check_same_shape(
    a: np.ndarray, b: np.ndarray, *, names: Sequence[str] = ("left", "right")
) -> None:
    """Raise ``ValueError`` unless ``a`` and ``b`` have the same shape.

    Examples
    --------
    >>> import numpy as np
    >>> check_same_shape(np.zeros((2, 3)), np.zeros((2, 3)))
    """
    if a.shape != b.shape:
        raise fail(f"{names[0]} and {names[1]}", "the same shape", f"{a.shape} and {b.shape}",
                   fix="crop or resize one of them")


def check_window(window: object, name: str, *, image_shape: Sequence[int]) -> int:
    """Validate a square window side: an odd integer, at least 3, at most ``min(H, W)``.

    Returns
    -------
    int
        The window side.

    Examples
    --------
    >>> check_window(5, "window", image_shape=(10, 12))
    5
    """
    w = check_int(window, name)
    limit = min(int(image_shape[0]), int(image_shape[1]))
    if w < 3 or w % 2 == 0:
        raise fail(name, "an odd integer >= 3", str(w), fix=f"try {max(3, w | 1)}")
    if w > limit:
        raise fail(name, f"at most min(H, W) = {limit} for an image of shape "
                   f"{tuple(image_shape)}", str(w), fix="use a smaller window")
    return w


def check_max_disparity(max_disparity: object, width: int, *, name: str = "max_disparity") -> int:
    """Validate a disparity search bound ``D``: an integer with ``1 <= D < width``.

    Examples
    --------
    >>> check_max_disparity(16, 64)
    16
    """
    return check_int(max_disparity, name, lo=1, hi=width - 1,
                     fix=f"it must stay below the image width {width}")


def check_positive(value: object, name: str) -> float:
    """Validate a finite, strictly positive real number and return it as ``float``.

    Examples
    --------
    >>> check_positive(3, "delta")
    3.0
    """
    return check_real(value, name, lo=0, lo_open=True)


def check_disparity_map(
    disparity: object,
    name: str,
    *,
    shape: Sequence[int] | None = None,
    allow_integer: bool = False,
) -> np.ndarray:
    """Validate a 2-D disparity map (``inf``/NaN mark invalid pixels).

    Parameters
    ----------
    disparity : (H, W) float32 or float64 array
        Disparity in pixels.
    name : str
        Parameter name used in error messages.
    shape : (int, int), optional
        Required shape.
    allow_integer : bool, default False
        Accept integer dtypes (converted to ``float64``). Off by default because an integer map
        cannot mark invalid pixels, and a raw file code such as Middlebury's 0 must not pass as a
        real disparity.

    Returns
    -------
    (H, W) float array
        The map, unchanged when already float.

    Examples
    --------
    >>> import numpy as np
    >>> check_disparity_map(np.full((2, 2), np.inf, np.float32), "gt").dtype
    dtype('float32')
    """
    check_array(disparity, name)
    allowed = "float or integer" if allow_integer else "float32 or float64"
    check_dtype(disparity, name, kinds="fui" if allow_integer else "f",
                expected=f"a {allowed} disparity map",
                fix="convert with .astype(np.float32) and mark invalid pixels with inf")
    if disparity.ndim != 2:
        raise fail(name, "a 2-D (H, W) map", f"shape {disparity.shape}")
    if shape is not None:
        check_shape(disparity, name, shape)
    if disparity.dtype.kind != "f":
        return disparity.astype(np.float64)
    return disparity


#: Codes of an occlusion mask (``mask0nocc.png``): no ground truth, occluded, visible in both.
MASK_CODES: tuple[int, int, int] = (0, 128, 255)


def check_occlusion_mask(mask: object, name: str, *, shape: Sequence[int] | None = None) -> np.ndarray:
    """Validate an occlusion mask: (H, W) uint8 with only the codes 0, 128 and 255.

    Examples
    --------
    >>> import numpy as np
    >>> check_occlusion_mask(np.array([[0, 128, 255]], np.uint8), "mask").shape
    (1, 3)
    """
    expected, fix = "a uint8 mask with codes 0/128/255", "convert with .astype(np.uint8)"
    check_type(mask, name, np.ndarray, expected=expected, fix=fix)
    check_dtype(mask, name, dtypes=(np.uint8,), expected=expected, fix=fix)
    if mask.ndim != 2:
        raise fail(name, "a 2-D (H, W) mask", f"shape {mask.shape}")
    if shape is not None:
        check_shape(mask, name, shape)
    none, occluded, visible = MASK_CODES
    bad = (mask != none) & (mask != occluded) & (mask != visible)  # 25x faster than np.unique
    if bad.any():
        extra = np.unique(mask[bad])
        raise fail(name, "only the codes 0 (no ground truth), 128 (occluded), 255 (visible)",
                   f"also {extra[:5].tolist()}")
    return mask


def check_ground_truth(
    disparity: object,
    name: str,
    *,
    shape: Sequence[int] | None = None,
    mask: np.ndarray | None = None,
) -> np.ndarray:
    """Validate a ground-truth disparity map before it is written to a dataset.

    Finite values must be ``>= 0``; ``inf`` and NaN mean "no ground truth" (``-inf`` is refused).
    With ``mask`` (validated by :func:`check_occlusion_mask`), a pixel must have finite ground
    truth exactly where ``mask != 0``.

    Returns
    -------
    (H, W) float32 array
        A copy with NaN replaced by ``inf``.

    Examples
    --------
    >>> import numpy as np
    >>> check_ground_truth(np.array([[1.5, np.nan]]), "disp").tolist()
    [[1.5, inf]]
    """
    disp = check_disparity_map(disparity, name, shape=shape)
    out = disp.astype(np.float32)  # float64 beyond float32 range becomes inf: still no GT
    out[np.isnan(out)] = np.inf
    finite = np.isfinite(out)
    bad = out < 0  # finite negatives and -inf
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise fail(name, "disparities >= 0 (inf for no ground truth)",
                   f"{out[i, j]} at row {i}, column {j} ({int(bad.sum())} such pixels)")
    if mask is not None:
        if mask.shape != out.shape:
            raise fail(f"{name} and mask", "the same shape", f"{out.shape} and {mask.shape}")
        wrong = finite != (mask != 0)
        if wrong.any():
            i, j = np.argwhere(wrong)[0]
            raise fail(name, "ground truth finite exactly where the mask is 128 or 255",
                       f"at row {i}, column {j} the mask is {mask[i, j]} and {name} is "
                       f"{out[i, j]} ({int(wrong.sum())} such pixels)")
    return out
