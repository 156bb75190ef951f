"""Validation helpers shared by the public functions of :mod:`matcher`.

Every public function validates its input once, here, and raises a :class:`ValueError` or
:class:`TypeError` that names the parameter, the expected and the actual value, and the fix.
Kernels downstream trust what these helpers return.

Other modules may append helpers; keep each one small and keep the message format
``"<name>: expected <what>, got <actual>; <fix>"``.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np

__all__ = [
    "GREY_WEIGHTS",
    "MASK_CODES",
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


def _describe(x: object) -> str:
    if isinstance(x, np.ndarray):
        return f"array of shape {x.shape} and dtype {x.dtype}"
    return f"{type(x).__name__} {x!r}"


def rgb_to_grey(image: np.ndarray) -> np.ndarray:
    """Convert an ``(H, W, 3)`` RGB array to grey with :data:`GREY_WEIGHTS`.

    ``uint8`` input gives ``uint8`` output (rounded half up, clipped to 0..255, like OpenCV);
    float input gives output of the same float dtype; other integer input gives ``float64``.
    Input is trusted (no validation): use :func:`check_image` at a public boundary.
    """
    w = np.asarray(GREY_WEIGHTS, dtype=np.float64)
    if image.dtype == np.uint8:
        grey = image.astype(np.float64) @ w
        return np.clip(np.floor(grey + 0.5), 0, 255).astype(np.uint8)
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
    if not isinstance(image, np.ndarray):
        raise TypeError(
            f"{name}: expected a numpy array, got {_describe(image)}; convert with np.asarray"
        )
    if image.dtype == np.bool_ or image.dtype.kind not in "uif":
        raise TypeError(
            f"{name}: expected a uint8, integer or float image, got dtype {image.dtype}; "
            "convert with .astype(np.uint8) or .astype(np.float32)"
        )
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise ValueError(
            f"{name}: expected shape (H, W), (H, W, 1) or (H, W, 3) (RGB), got {image.shape}; "
            "drop an alpha channel with image[..., :3]"
        )
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise ValueError(f"{name}: expected a non-empty image, got shape {image.shape}")
    if image.dtype.kind == "f" and not np.isfinite(image).all():
        raise ValueError(
            f"{name}: expected finite pixel values, got {int((~np.isfinite(image)).sum())} "
            "NaN/inf pixels; replace them (e.g. np.nan_to_num) before matching"
        )
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
        raise ValueError(
            f"{names[0]} and {names[1]}: expected the same shape, got {a.shape} and {b.shape}; "
            "crop or resize one of them"
        )


def _as_int(value: object, name: str) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name}: expected an integer, got {_describe(value)}")
    return int(value)


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
    w = _as_int(window, name)
    limit = min(int(image_shape[0]), int(image_shape[1]))
    if w < 3 or w % 2 == 0:
        raise ValueError(f"{name}: expected an odd integer >= 3, got {w}; try {max(3, w | 1)}")
    if w > limit:
        raise ValueError(
            f"{name}: expected at most min(H, W) = {limit} for an image of shape "
            f"{tuple(image_shape)}, got {w}; use a smaller window"
        )
    return w


def check_max_disparity(max_disparity: object, width: int, *, name: str = "max_disparity") -> int:
    """Validate a disparity search bound ``D``: an integer with ``1 <= D < width``.

    Examples
    --------
    >>> check_max_disparity(16, 64)
    16
    """
    d = _as_int(max_disparity, name)
    if not 1 <= d < width:
        raise ValueError(
            f"{name}: expected an integer in [1, {width - 1}] (below the image width {width}), "
            f"got {d}"
        )
    return d


def check_positive(value: object, name: str) -> float:
    """Validate a finite, strictly positive real number and return it as ``float``.

    Examples
    --------
    >>> check_positive(3, "delta")
    3.0
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a positive real number, got {_describe(value)}")
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name}: expected a finite number > 0, got {v}")
    return v


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
    if not isinstance(disparity, np.ndarray):
        raise TypeError(
            f"{name}: expected a numpy array, got {_describe(disparity)}; convert with np.asarray"
        )
    kind = disparity.dtype.kind
    if not (kind == "f" or (allow_integer and kind in "ui")):
        allowed = "float or integer" if allow_integer else "float32 or float64"
        raise TypeError(
            f"{name}: expected a {allowed} disparity map, got dtype {disparity.dtype}; "
            "convert with .astype(np.float32) and mark invalid pixels with inf"
        )
    if disparity.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D (H, W) map, got shape {disparity.shape}")
    if shape is not None and disparity.shape != tuple(shape):
        raise ValueError(f"{name}: expected shape {tuple(shape)}, got {disparity.shape}")
    if kind != "f":
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
    if not isinstance(mask, np.ndarray) or mask.dtype != np.uint8:
        got = f"dtype {mask.dtype}" if isinstance(mask, np.ndarray) else _describe(mask)
        raise TypeError(
            f"{name}: expected a uint8 mask with codes 0/128/255, got {got}; "
            "convert with .astype(np.uint8)"
        )
    if mask.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D (H, W) mask, got shape {mask.shape}")
    if shape is not None and mask.shape != tuple(shape):
        raise ValueError(f"{name}: expected shape {tuple(shape)}, got {mask.shape}")
    none, occluded, visible = MASK_CODES
    bad = (mask != none) & (mask != occluded) & (mask != visible)  # 25x faster than np.unique
    if bad.any():
        extra = np.unique(mask[bad])
        raise ValueError(
            f"{name}: expected only the codes 0 (no ground truth), 128 (occluded), "
            f"255 (visible), got also {extra[:5].tolist()}"
        )
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
        raise ValueError(
            f"{name}: expected disparities >= 0 (inf for no ground truth), got {out[i, j]} at "
            f"row {i}, column {j} ({int(bad.sum())} such pixels)"
        )
    if mask is not None:
        if mask.shape != out.shape:
            raise ValueError(f"{name} and mask: shapes differ, {out.shape} vs {mask.shape}")
        wrong = finite != (mask != 0)
        if wrong.any():
            i, j = np.argwhere(wrong)[0]
            raise ValueError(
                f"{name}: ground truth must be finite exactly where the mask is 128 or 255; "
                f"at row {i}, column {j} the mask is {mask[i, j]} and {name} is {out[i, j]} "
                f"({int(wrong.sum())} such pixels)"
            )
    return out
