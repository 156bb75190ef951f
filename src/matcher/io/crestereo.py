"""CREStereo disparity PNGs (``<id>_left.disp.png``, ``<id>_right.disp.png``): one 16-bit grey
channel holding ``round(d * 32)``, 0 = no ground truth (see ``docs/formats.md``).

CREStereo's own reader (``dataset.py``, ``CREStereoDataset.get_disp`` of
megvii-research/CREStereo) is::

    disp = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    return disp.astype(np.float32) / 32

and its augmentor keeps ``left_disp > 0`` (and below the training range) as the valid mask: a
code 0 is a pixel without ground truth. :func:`decode_crestereo_disparity` returns exactly those
float32 values, with ``inf`` where the code is 0.

The quantum is 1/32 px, so a stored disparity is within 1/64 px of the true one. The largest
code 65535 is :data:`CRESTEREO_MAX` = 65535 / 32 = 2047.96875 px. A disparity that cannot be
stored is refused, never clipped: a negative one, one whose code would exceed 65535, and a
finite one of at most 1/64 px (its code would be 0, "no ground truth").
"""

from __future__ import annotations

import os

import numpy as np

from matcher.io._coded_png import (
    CodedDisparity,
    check_code_range,
    decode_png_bytes,
    disparity_codes,
    read_file_bytes,
)
from matcher.io.png import encode_png

__all__ = ["CRESTEREO_MAX", "CRESTEREO_SCALE", "check_crestereo_range", "decode_crestereo_disparity",
           "encode_crestereo_disparity", "read_crestereo_disparity"]

#: Codes per pixel of disparity: the file holds ``round(d * 32)``.
CRESTEREO_SCALE = 32
#: The largest disparity a CREStereo PNG holds: ``65535 / 32 = 2047.96875`` px.
CRESTEREO_MAX = 65535 / CRESTEREO_SCALE

_CODEC = CodedDisparity("CREStereo", "16-bit PNG", CRESTEREO_SCALE, 65535)


def encode_crestereo_disparity(disp: np.ndarray) -> bytes:
    """Encode a disparity map as the bytes of a CREStereo disparity PNG.

    Parameters
    ----------
    disp : (H, W) float32 or float64 array
        Disparity in pixels; ``inf`` or NaN where there is no ground truth. Finite values must
        lie in ``(1/64, CRESTEREO_MAX]`` (see :func:`check_crestereo_range`).

    Returns
    -------
    bytes
        A 16-bit grey PNG of ``round(d * 32)`` (0 where there is no ground truth), written by
        :func:`~matcher.io.png.encode_png`: the same map gives the same bytes.

    Raises
    ------
    ValueError
        If a finite value is negative, above :data:`CRESTEREO_MAX` (the message names the
        largest), or at most 1/64 px (it would read as "no ground truth").
    TypeError
        If ``disp`` is not a float array.

    Examples
    --------
    >>> import numpy as np
    >>> png = encode_crestereo_disparity(np.array([[1.5, np.inf, 2047.96875]], np.float32))
    >>> decode_crestereo_disparity(png).tolist()
    [[1.5, inf, 2047.96875]]
    >>> encode_crestereo_disparity(np.array([[3000.0]]))
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: disp: expected disparities <= 2047.96875 px, the most CREStereo's 16-bit PNG holds (round(d * 32) <= 65535), got a largest value of 3000.0 px at row 0, column 0 (1 pixel above); lower the baseline or the focal length (or move the nearest surface away), or write a layout that stores float disparities (PFM)
    """
    codes = disparity_codes(_CODEC, disp, "disp")
    return encode_png(codes.astype(np.uint16))


def decode_crestereo_disparity(data: bytes, *, path: str | os.PathLike[str] | None = None
                               ) -> np.ndarray:
    """Decode the bytes of a CREStereo disparity PNG.

    Parameters
    ----------
    data : bytes, bytearray or memoryview
        The whole file.
    path : str or path-like, optional
        The file the bytes came from, for messages.

    Returns
    -------
    (H, W) float32 array
        ``code / 32`` as CREStereo's ``get_disp`` computes it, ``inf`` where the code is 0.

    Raises
    ------
    FormatError
        If the bytes are not a 16-bit one-channel PNG, or are truncated or corrupt.
    TypeError
        If ``data`` is not bytes-like.

    Examples
    --------
    >>> import numpy as np
    >>> from matcher.io import encode_png
    >>> decode_crestereo_disparity(encode_png(np.array([[0, 1, 64]], np.uint16)))
    array([[    inf, 0.03125, 2.     ]], dtype=float32)
    """
    where = "CREStereo disparity data" if path is None else str(path)
    raw = decode_png_bytes(data, where, layout="CREStereo", depth=16, channels={0: 1},
                           expected="16-bit grey (one channel)")
    disp = raw.astype(np.float32) / np.float32(CRESTEREO_SCALE)
    disp[raw == 0] = np.inf
    return disp


def read_crestereo_disparity(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a CREStereo disparity PNG (see :func:`decode_crestereo_disparity`).

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    FormatError
        If it is not a 16-bit one-channel PNG, or is truncated or corrupt.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = pathlib.Path(d, "0_left.disp.png")
    ...     _ = p.write_bytes(encode_crestereo_disparity(np.array([[4.25]])))
    ...     read_crestereo_disparity(p)
    array([[4.25]], dtype=float32)
    """
    return decode_crestereo_disparity(read_file_bytes(path), path=path)


def check_crestereo_range(disp_min: float, disp_max: float) -> None:
    """Refuse a range of finite disparities that a CREStereo PNG cannot hold, before rendering.

    Parameters
    ----------
    disp_min, disp_max : float
        The smallest and the largest finite disparity (pixels) the data will hold.

    Raises
    ------
    ValueError
        If ``disp_min`` is negative or at most 1/64 px (it would be stored as code 0, "no
        ground truth"), ``disp_max < disp_min``, or ``disp_max`` is above :data:`CRESTEREO_MAX`.
    TypeError
        If either is not a real number.

    Examples
    --------
    >>> check_crestereo_range(0.5, 300.0)
    >>> check_crestereo_range(0.01, 300.0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: disp_min: expected finite disparities > 0.015625 px (smaller ones round to code 0, which CREStereo files read as 'no ground truth'), got 0.01 px; mark pixels without ground truth with inf, or keep every surface near enough (or widen the baseline) that its disparity stays above that minimum
    """
    check_code_range(_CODEC, disp_min, disp_max)
