"""JPEG images for the training layouts that store their views as JPEG (CREStereo's
``<id>_left.jpg``, FoundationStereo's ``left/rgb/NNNN.jpg``), written near-losslessly.

:func:`encode_jpeg` writes baseline JPEG with OpenCV (libjpeg-turbo) at quality >= 95 and
**without chroma subsampling** (4:4:4: every component sampled 1x1), so colour edges stay
sharp; grey images are one-component files. The bytes depend only on the pixels, the quality
and the libjpeg-turbo version (no timestamp or metadata is written). The mean absolute
difference from the lossless image, measured on real and synthetic images, is in
``docs/formats.md``. Read the files back with :func:`matcher.io.read_image`.
"""

from __future__ import annotations

import cv2
import numpy as np

from matcher._validation import check_int
from stereoforge.validation import check_array, check_dtype, fail

__all__ = ["JPEG_MAX_SIDE", "JPEG_MIN_QUALITY", "encode_jpeg"]

#: The lowest quality :func:`encode_jpeg` writes.
JPEG_MIN_QUALITY = 95
#: The largest width or height a JPEG file can hold.
JPEG_MAX_SIDE = 65500


def encode_jpeg(image: np.ndarray, *, quality: int = 95) -> bytes:
    """Encode an image as the bytes of a baseline JPEG, 4:4:4 (no chroma subsampling).

    Parameters
    ----------
    image : (H, W, 3) uint8 array (RGB order) or (H, W) uint8 array (grey)
        Any strides; sides at most :data:`JPEG_MAX_SIDE`.
    quality : int, default 95
        libjpeg quality, :data:`JPEG_MIN_QUALITY` (95) to 100.

    Returns
    -------
    bytes
        A JFIF file (one ``SOF0`` frame, every component sampled 1x1). The same image and
        quality give the same bytes.

    Raises
    ------
    TypeError
        If ``image`` is not a uint8 array or ``quality`` not an integer.
    ValueError
        If ``image`` has another shape, is empty or too large, or ``quality`` is outside 95..100.

    Examples
    --------
    >>> import cv2, numpy as np
    >>> img = np.full((8, 8, 3), (200, 30, 90), np.uint8)
    >>> jpg = encode_jpeg(img, quality=98)
    >>> jpg[:2] == b"\\xff\\xd8"
    True
    >>> back = cv2.imdecode(np.frombuffer(jpg, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
    >>> int(np.abs(back.astype(int) - img).max()) <= 2
    True
    """
    check_array(image, "image")
    check_dtype(image, "image", dtypes=[np.uint8], expected="a uint8 image",
                fix="convert with np.clip(image, 0, 255).astype(np.uint8)")
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise fail("image", "shape (H, W) or (H, W, 3) (RGB)", str(image.shape),
                   fix="drop an alpha channel with image[..., :3]")
    h, w = image.shape[:2]
    if not (0 < h <= JPEG_MAX_SIDE and 0 < w <= JPEG_MAX_SIDE):
        raise fail("image", f"a non-empty image with sides <= {JPEG_MAX_SIDE}", f"shape {image.shape}",
                   fix="write it as PNG (matcher.io.encode_png)")
    quality = check_int(quality, "quality", lo=JPEG_MIN_QUALITY, hi=100,
                        fix="lower qualities blur texture that stereo matching relies on")
    pixels = np.ascontiguousarray(image[..., ::-1] if image.ndim == 3 else image)
    params = [cv2.IMWRITE_JPEG_QUALITY, quality,
              cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444,
              cv2.IMWRITE_JPEG_OPTIMIZE, 0, cv2.IMWRITE_JPEG_PROGRESSIVE, 0]
    ok, buf = cv2.imencode(".jpg", pixels, params)
    if not ok:  # pragma: no cover - libjpeg refuses only what is checked above
        raise RuntimeError(f"OpenCV could not encode a {image.shape} image as JPEG")
    return buf.tobytes()
