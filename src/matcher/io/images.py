"""Reading images and ground-truth disparity maps (PNG via OpenCV, PFM).

Disparity files use three encodings (see ``docs/formats.md``):

* PFM: float32 disparity in pixels, ``inf`` where there is no ground truth (Middlebury 2014).
* 8-bit PNG: ``value / divisor`` pixels, ``0`` = unknown (Middlebury 2005/2006: divisor 1, 2 or
  3 for the full, half and third size).
* 16-bit PNG: ``value / 256`` pixels, ``0`` = invalid (KITTI 2012/2015).

Every reader returns ``inf`` where the file says "no ground truth", never 0.
"""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from matcher._validation import check_positive
from matcher.io.pfm import read_pfm

__all__ = ["KITTI_DIVISOR", "PNG_COMPRESSION", "decode_disparity_png", "encode_png", "read_disparity", "read_image"]

#: zlib level of the PNGs we write. With the RLE strategy and libpng's fast filters (see
#: :func:`encode_png`) a 640x480 RGB PNG encodes in ~8 ms instead of ~10-35 ms (OpenCV
#: defaults); masks and disparity maps get smaller, smooth colour images up to ~3x larger.
PNG_COMPRESSION = 1

#: The divisor of KITTI's 16-bit disparity PNGs.
KITTI_DIVISOR = 256.0


def _imread(path: Path, flags: int) -> np.ndarray:
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    # np.fromfile + imdecode handles non-ASCII paths, which cv2.imread does not on every platform.
    data = np.fromfile(path, dtype=np.uint8)
    image = cv2.imdecode(data, flags) if data.size else None
    if image is None:
        raise ValueError(f"{path}: not an image OpenCV can decode (corrupt or unsupported format)")
    return image


def read_image(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an 8-bit image (PNG or any format OpenCV decodes).

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    (H, W, 3) uint8 array (RGB order) or (H, W) uint8 array (grey files)
        Colour files are returned in R, G, B order (an alpha channel is dropped); 16-bit files
        are rejected rather than silently rescaled.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If OpenCV cannot decode it or it is not 8-bit.

    Examples
    --------
    >>> import tempfile, cv2, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = cv2.imwrite(f"{d}/a.png", np.array([[[0, 0, 255]]], np.uint8))  # BGR red
    ...     read_image(f"{d}/a.png")[0, 0].tolist()
    [255, 0, 0]
    """
    path = Path(path)
    image = _imread(path, cv2.IMREAD_UNCHANGED)
    if image.dtype != np.uint8:
        raise ValueError(
            f"{path}: expected an 8-bit image, got dtype {image.dtype}; "
            "for 16-bit disparity maps use read_disparity"
        )
    if image.ndim == 3:
        if image.shape[2] == 4:
            return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
        return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    return image


def decode_disparity_png(raw: np.ndarray, *, divisor: float, where: str = "disparity") -> np.ndarray:
    """Turn the integer codes of a disparity PNG into float32 pixels (0 becomes ``inf``).

    Parameters
    ----------
    raw : (H, W) uint8 or uint16 array
        Stored codes.
    divisor : float
        Codes per pixel of disparity (> 0).
    where : str
        Name used in error messages.

    Returns
    -------
    (H, W) float32 array

    Examples
    --------
    >>> import numpy as np
    >>> decode_disparity_png(np.array([[0, 6]], np.uint8), divisor=3)
    array([[inf,  2.]], dtype=float32)
    """
    divisor = check_positive(divisor, "divisor")
    if raw.dtype not in (np.uint8, np.uint16) or raw.ndim != 2:
        raise ValueError(
            f"{where}: expected a single-channel 8- or 16-bit disparity image, got shape "
            f"{raw.shape} and dtype {raw.dtype}"
        )
    disp = raw.astype(np.float32) / np.float32(divisor)
    disp[raw == 0] = np.inf
    return disp


def read_disparity(path: str | os.PathLike[str], *, divisor: float | None = None) -> np.ndarray:
    """Read a ground-truth disparity map from a PFM or PNG file.

    Parameters
    ----------
    path : str or path-like
        A ``.pfm`` file (float disparity, returned as stored) or a PNG (integer codes).
    divisor : float, optional
        PNG codes per pixel of disparity. Required for 8-bit PNGs (Middlebury 2005/2006: 3 for
        the third size, 2 for the half size, 1 for the full size); defaults to 256 for 16-bit
        PNGs (KITTI). Must be None for PFM files.

    Returns
    -------
    (H, W) float32 array
        Disparity in pixels; ``inf`` where the file stores 0 (PNG) or ``inf`` (PFM). A PFM file
        may also hold NaN, which is returned as is and is likewise treated as "no ground truth".

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If the file is unreadable, colour, or an 8-bit PNG is read without a divisor.

    Examples
    --------
    >>> import tempfile, cv2, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = cv2.imwrite(f"{d}/d.png", np.array([[0, 512]], np.uint16))
    ...     read_disparity(f"{d}/d.png")
    array([[inf,  2.]], dtype=float32)
    """
    path = Path(path)
    if path.suffix.lower() == ".pfm":
        if divisor is not None:
            raise ValueError(f"divisor: a PFM file stores pixels directly, got divisor={divisor}; pass None")
        disp = read_pfm(path)
        if disp.ndim != 2:
            raise ValueError(f"{path}: expected a grey (Pf) disparity PFM, got shape {disp.shape}")
        return disp
    raw = _imread(path, cv2.IMREAD_UNCHANGED)
    if raw.ndim == 3:
        if not (raw == raw[:, :, :1]).all():
            raise ValueError(f"{path}: a disparity PNG must be single-channel, got {raw.shape[2]} distinct channels")
        raw = np.ascontiguousarray(raw[:, :, 0])
    if divisor is None:
        if raw.dtype != np.uint16:
            raise ValueError(
                f"divisor: required for the 8-bit disparity PNG {path} (Middlebury: 3 for the "
                "third size, 2 for half, 1 for full)"
            )
        divisor = KITTI_DIVISOR
    return decode_disparity_png(raw, divisor=divisor, where=str(path))


def encode_png(image: np.ndarray, *, compression: int = PNG_COMPRESSION) -> bytes:
    """Encode an image as PNG bytes (lossless).

    Parameters
    ----------
    image : (H, W) uint8/uint16 array or (H, W, 3) uint8 array (RGB order)
        Pixel data; colour is converted to OpenCV's BGR order before encoding.
    compression : int, default 1
        zlib level 0..9 (low is fast). The zlib strategy is RLE and libpng chooses among its
        fast row filters (None/Sub/Up): a speed/size trade-off measured on rendered images,
        noise, masks and 16-bit disparities.

    Returns
    -------
    bytes

    Examples
    --------
    >>> import numpy as np
    >>> encode_png(np.zeros((2, 2), np.uint8))[:4]
    b'\\x89PNG'
    """
    if not isinstance(image, np.ndarray) or image.dtype not in (np.uint8, np.uint16):
        got = f"dtype {image.dtype}" if isinstance(image, np.ndarray) else type(image).__name__
        raise TypeError(f"image: expected a uint8 or uint16 array, got {got}")
    if image.ndim == 3 and image.shape[2] == 3:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    elif image.ndim != 2:
        raise ValueError(f"image: expected shape (H, W) or (H, W, 3), got {image.shape}")
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise ValueError(f"image: expected a non-empty image, got shape {image.shape}")
    params = [
        cv2.IMWRITE_PNG_COMPRESSION, int(compression),
        cv2.IMWRITE_PNG_STRATEGY, cv2.IMWRITE_PNG_STRATEGY_RLE,
        cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FAST_FILTERS,
    ]
    ok, buf = cv2.imencode(".png", image, params)
    if not ok:  # pragma: no cover - OpenCV failure
        raise ValueError("image: OpenCV could not encode the PNG")
    return buf.tobytes()
