"""FoundationStereo's FSD disparity PNGs (``left/disparity/NNNN.png``): 8-bit RGB holding the
integer ``round(d * 1000)`` in base 255, R the most significant digit (see ``docs/formats.md``).

FoundationStereo's own decoder (``Utils.py`` of NVlabs/FoundationStereo, called by
``scripts/vis_dataset.py`` on ``imageio.imread(f'{root}/left/disparity/0000.png')``, which
returns R, G, B in that order) is::

    def depth_uint8_decoding(depth_uint8, scale=1000):
      depth_uint8 = depth_uint8.astype(float)
      out = depth_uint8[...,0]*255*255 + depth_uint8[...,1]*255 + depth_uint8[...,2]
      return out/float(scale)

:func:`decode_fsd_disparity` computes exactly that (in float64) and returns it as float32, with
``inf`` where the code is 0: FoundationStereo's code names no invalid value (its decoder returns
0 px there); code 0 is ours for "no ground truth", and :func:`encode_fsd_disparity` never writes
it for a finite disparity.

The writer stores the digits ``R = c // 255**2``, ``G = c // 255 % 255``, ``B = c % 255`` of
``c = round(d * 1000)``, each in 0..254, so the largest code is ``255**3 - 1`` and the largest
disparity :data:`FSD_MAX` = 16581.374 px. The quantum is 1/1000 px: the code is within 0.0005 px
of the disparity (float32 adds its own rounding, half a unit in the last place: ~3e-5 px at
1000 px, ~1e-3 px above 16384 px). A disparity that cannot be stored is refused, never
clipped: a negative one, one above :data:`FSD_MAX`, and a finite one of at most 0.0005 px (its
code would be 0).
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

__all__ = ["FSD_BASE", "FSD_MAX", "FSD_SCALE", "check_fsd_range", "decode_fsd_disparity",
           "encode_fsd_disparity", "read_fsd_disparity"]

#: Codes per pixel of disparity: the file holds ``round(d * 1000)``.
FSD_SCALE = 1000
#: The base of the three digits (R, G, B): 255, not 256.
FSD_BASE = 255
#: The largest disparity the encoder writes: ``(255**3 - 1) / 1000 = 16581.374`` px.
FSD_MAX = (FSD_BASE**3 - 1) / FSD_SCALE

_CODEC = CodedDisparity("FSD", "RGB PNG", FSD_SCALE, FSD_BASE**3 - 1)


def encode_fsd_disparity(disp: np.ndarray) -> bytes:
    """Encode a disparity map as the bytes of an FSD disparity PNG.

    Parameters
    ----------
    disp : (H, W) float32 or float64 array
        Disparity in pixels; ``inf`` or NaN where there is no ground truth. Finite values must
        lie in ``(0.0005, FSD_MAX]`` (see :func:`check_fsd_range`).

    Returns
    -------
    bytes
        An 8-bit RGB PNG, ``(R, G, B)`` the base-255 digits of ``round(d * 1000)`` (``(0, 0, 0)``
        where there is no ground truth), deflated by libdeflate: the same map gives the same
        bytes on every machine.

    Raises
    ------
    ValueError
        If a finite value is negative, above :data:`FSD_MAX` (the message names the largest),
        or at most 0.0005 px (it would be stored as code 0).
    TypeError
        If ``disp`` is not a float array.

    Examples
    --------
    >>> import cv2, numpy as np
    >>> png = encode_fsd_disparity(np.array([[1.5, 70.0, np.inf]]))
    >>> cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)[..., ::-1].tolist()
    [[[0, 5, 225], [1, 19, 130], [0, 0, 0]]]
    >>> decode_fsd_disparity(png)
    array([[ 1.5, 70. ,  inf]], dtype=float32)
    """
    codes = disparity_codes(_CODEC, disp, "disp")
    rgb = np.stack([codes // FSD_BASE**2, codes // FSD_BASE % FSD_BASE, codes % FSD_BASE], axis=-1)
    return encode_png(rgb.astype(np.uint8), deflate="libdeflate")


def decode_fsd_disparity(data: bytes, *, path: str | os.PathLike[str] | None = None) -> np.ndarray:
    """Decode the bytes of an FSD disparity PNG.

    Parameters
    ----------
    data : bytes, bytearray or memoryview
        The whole file: an 8-bit RGB PNG (an alpha channel, if any, is ignored, as
        FoundationStereo's decoder ignores it).
    path : str or path-like, optional
        The file the bytes came from, for messages.

    Returns
    -------
    (H, W) float32 array
        ``(R * 255 * 255 + G * 255 + B) / 1000`` as FoundationStereo's ``depth_uint8_decoding``
        computes it (in float64), ``inf`` where the code is 0. Digits of 255, which the encoder
        never writes, are decoded by the same formula.

    Raises
    ------
    FormatError
        If the bytes are not an 8-bit RGB(A) PNG, or are truncated or corrupt.
    TypeError
        If ``data`` is not bytes-like.

    Examples
    --------
    >>> import numpy as np
    >>> from matcher.io import encode_png
    >>> decode_fsd_disparity(encode_png(np.array([[[0, 0, 0], [0, 0, 1], [1, 2, 3]]], np.uint8)))
    array([[       inf, 1.0000e-03, 6.5538e+01]], dtype=float32)
    """
    where = "FSD disparity data" if path is None else str(path)
    bgr = decode_png_bytes(data, where, layout="FSD", depth=8, channels={2: 3, 6: 4},
                           expected="8-bit RGB")
    digits = bgr.astype(np.float64)
    code = digits[..., 2] * 255 * 255 + digits[..., 1] * 255 + digits[..., 0]  # R, G, B
    disp = (code / float(FSD_SCALE)).astype(np.float32)
    disp[code == 0] = np.inf
    return disp


def read_fsd_disparity(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an FSD disparity PNG (see :func:`decode_fsd_disparity`).

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    FormatError
        If it is not an 8-bit RGB(A) PNG, or is truncated or corrupt.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = pathlib.Path(d, "0000.png")
    ...     _ = p.write_bytes(encode_fsd_disparity(np.array([[12.345]])))
    ...     read_fsd_disparity(p)
    array([[12.345]], dtype=float32)
    """
    return decode_fsd_disparity(read_file_bytes(path), path=path)


def check_fsd_range(disp_min: float, disp_max: float) -> None:
    """Refuse a range of finite disparities that an FSD PNG cannot hold, before rendering.

    Parameters
    ----------
    disp_min, disp_max : float
        The smallest and the largest finite disparity (pixels) the data will hold.

    Raises
    ------
    ValueError
        If ``disp_min`` is negative or at most 0.0005 px (it would be stored as code 0),
        ``disp_max < disp_min``, or ``disp_max`` is above :data:`FSD_MAX`.
    TypeError
        If either is not a real number.

    Examples
    --------
    >>> check_fsd_range(0.001, 16581.374)
    >>> check_fsd_range(1.0, 20000.0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: disp_max: expected disparities <= 16581.374 px, the most FSD's RGB PNG holds (round(d * 1000) <= 16581374), got 20000.0 px; lower the baseline or the focal length (or move the nearest surface away), or write a layout that stores float disparities (PFM)
    """
    check_code_range(_CODEC, disp_min, disp_max)
