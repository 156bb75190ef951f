"""Disparity maps stored as integer codes in a PNG (``code = round(d * scale)``, 0 = no ground
truth): the range and precision checks and the bounded PNG decoding that the CREStereo
(:mod:`~matcher.io.crestereo`) and FoundationStereo (:mod:`~matcher.io.fsd`) codecs share.

A disparity a layout cannot hold is refused, never clipped: a finite value whose code would
exceed the largest code, a negative one, and one so small that its code would be 0 (which the
file reads as "no ground truth").

Decoding checks the PNG signature and ``IHDR`` (bit depth, colour type, size) before OpenCV sees
the bytes, so a header announcing more pixels than the bytes can hold (deflate expands at most
~1032-fold) is refused before anything is allocated.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from matcher._validation import check_disparity_map, check_real
from stereoforge.errors import FormatError
from stereoforge.validation import check_type, fail

__all__ = ["CodedDisparity", "check_code_range", "decode_png_bytes", "disparity_codes",
           "read_file_bytes"]

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: The most a deflate stream expands (258 bytes from ~2 bits); a PNG's rows can be no larger.
_MAX_INFLATE = 1032
_FIX_LARGE = ("lower the baseline or the focal length (or move the nearest surface away), or "
              "write a layout that stores float disparities (PFM)")
_FIX_SMALL = ("mark pixels without ground truth with inf, or keep every surface near enough "
              "(or widen the baseline) that its disparity stays above that minimum")


@dataclass(frozen=True)
class CodedDisparity:
    """How one layout stores disparity as integer codes.

    Attributes
    ----------
    layout : str
        Name for messages (``"CREStereo"``).
    file : str
        What the file is, for messages (``"16-bit PNG"``).
    scale : float
        Codes per pixel of disparity.
    max_code : int
        Largest code the file holds.
    """

    layout: str
    file: str
    scale: float
    max_code: int

    @property
    def max_disparity(self) -> float:
        """The largest disparity the file holds (``max_code / scale``)."""
        return self.max_code / self.scale

    @property
    def min_disparity(self) -> float:
        """Finite disparities must exceed this (``0.5 / scale``): smaller ones round to code 0."""
        return 0.5 / self.scale

    def _too_large(self) -> str:
        return (f"disparities <= {self.max_disparity} px, the most {self.layout}'s {self.file} "
                f"holds (round(d * {self.scale:g}) <= {self.max_code})")

    def _too_small(self) -> str:
        return (f"finite disparities > {self.min_disparity:g} px (smaller ones round to code 0, "
                f"which {self.layout} files read as 'no ground truth')")


def _pixels(where: np.ndarray) -> str:
    n = int(where.sum())
    return f"{n} pixel" if n == 1 else f"{n} pixels"


def disparity_codes(codec: CodedDisparity, disparity: object, name: str) -> np.ndarray:
    """The codes of ``disparity``: ``round(d * scale)`` where finite, 0 where ``inf``/NaN.

    Parameters
    ----------
    codec : CodedDisparity
    disparity : (H, W) float32 or float64 array
        Disparity in pixels; ``inf`` or NaN where there is no ground truth.
    name : str
        Parameter name for messages.

    Returns
    -------
    (H, W) int64 array
        Codes in ``0..codec.max_code``.

    Raises
    ------
    ValueError
        If a finite value is negative (or is ``-inf``), rounds to a code above ``max_code``
        (the message names the largest value), or rounds to code 0.
    TypeError
        If ``disparity`` is not a float array.
    """
    disp = check_disparity_map(disparity, name)
    if disp.size == 0:
        raise fail(name, "a non-empty (H, W) map", f"shape {disp.shape}")
    d = disp.astype(np.float64)
    negative = (d < 0) & ~np.isnan(d)  # finite negatives and -inf
    if negative.any():
        i, j = np.unravel_index(np.argmin(np.where(negative, d, np.inf)), d.shape)
        raise fail(name, "disparities >= 0 (inf or NaN where there is no ground truth)",
                   f"a smallest value of {disp[i, j]} px at row {i}, column {j} "
                   f"({_pixels(negative)} negative)",
                   fix="check the sign convention (left disparity = x_left - x_right)")
    finite = np.isfinite(d)
    q = np.zeros(d.shape, np.float64)
    q[finite] = np.rint(d[finite] * codec.scale)
    large = q > codec.max_code
    if large.any():
        i, j = np.unravel_index(np.argmax(np.where(finite, d, -np.inf)), d.shape)
        raise fail(name, codec._too_large(),
                   f"a largest value of {disp[i, j]} px at row {i}, column {j} "
                   f"({_pixels(large)} above)", fix=_FIX_LARGE)
    small = finite & (q < 1)
    if small.any():
        i, j = np.argwhere(small)[0]
        raise fail(name, codec._too_small(),
                   f"{disp[i, j]} px at row {i}, column {j} ({_pixels(small)} so small)",
                   fix=_FIX_SMALL)
    return q.astype(np.int64)


def check_code_range(codec: CodedDisparity, disp_min: object, disp_max: object) -> None:
    """Refuse a range of finite disparities ``[disp_min, disp_max]`` the layout cannot hold.

    Raises
    ------
    ValueError
        If ``disp_min`` is negative or rounds to code 0, ``disp_max < disp_min``, or ``disp_max``
        rounds to a code above ``max_code``.
    TypeError
        If either is not a real number.
    """
    lo = check_real(disp_min, "disp_min", lo=0.0)
    hi = check_real(disp_max, "disp_max", lo=lo,
                    fix="pass the smallest and the largest finite disparity, in that order")
    if np.rint(hi * codec.scale) > codec.max_code:
        raise fail("disp_max", codec._too_large(), f"{hi} px", fix=_FIX_LARGE)
    if np.rint(lo * codec.scale) < 1:
        raise fail("disp_min", codec._too_small(), f"{lo} px", fix=_FIX_SMALL)


def read_file_bytes(path: str | os.PathLike[str]) -> bytes:
    """The bytes of ``path`` (:func:`matcher.io.files.read_file`: a regular file, within the
    size limit); :class:`FileNotFoundError` naming it if there is none."""
    from matcher.io.files import read_file

    return read_file(Path(path), what="disparity PNG")


def _png_header(data: bytes, where: str, layout: str) -> tuple[int, int, int, int]:
    """(width, height, bit depth, colour type) from the ``IHDR`` that must follow the signature."""
    if data[:8] != _SIGNATURE:
        raise FormatError(f"{where}: not a PNG file (it starts with {data[:8]!r}); {layout}'s "
                          "disparity map is a PNG")
    if len(data) < 33 or data[8:16] != b"\x00\x00\x00\x0dIHDR":
        raise FormatError(f"{where}: truncated or corrupt PNG (no 13-byte IHDR chunk after the "
                          f"signature, {len(data)} bytes in all)")
    width, height, depth, colour = struct.unpack(">IIBB", data[16:26])
    if width == 0 or height == 0:
        raise FormatError(f"{where}: corrupt PNG header: a {width}x{height} image")
    return width, height, depth, colour


def decode_png_bytes(data: object, where: str, *, layout: str, depth: int,
                     channels: dict[int, int], expected: str) -> np.ndarray:
    """Decode a PNG of the one bit depth and colour types a layout writes, with bounded memory.

    Parameters
    ----------
    data : bytes, bytearray or memoryview
        The whole file.
    where : str
        The file (or what the bytes are) for messages.
    layout : str
        The layout, for messages.
    depth : int
        Required bit depth (8 or 16).
    channels : dict
        Accepted PNG colour types and their channel counts (``{0: 1}`` grey, ``{2: 3}`` RGB).
    expected : str
        What the file must be, for messages (``"16-bit grey"``).

    Returns
    -------
    (H, W) or (H, W, C) uint8/uint16 array
        As OpenCV's ``imdecode(..., IMREAD_UNCHANGED)`` returns it (colour in **B, G, R** order).

    Raises
    ------
    FormatError
        If the bytes are not a PNG, the header is corrupt, of another bit depth or colour type,
        announces more pixels than the bytes can hold, or OpenCV cannot decode the data
        (truncated or corrupt).
    TypeError
        If ``data`` is not bytes-like.
    """
    check_type(data, "data", (bytes, bytearray, memoryview), expected="the bytes of a PNG file",
               fix="read the file with read_*_disparity(path) or Path(path).read_bytes()")
    data = bytes(data)
    width, height, bits, colour = _png_header(data, where, layout)
    if bits != depth or colour not in channels:
        raise FormatError(f"{where}: {layout}'s disparity PNG is {expected}, this one has bit "
                          f"depth {bits} and PNG colour type {colour}")
    row = 1 + (width * channels[colour] * depth + 7) // 8
    if height * row > _MAX_INFLATE * len(data):
        raise FormatError(f"{where}: the header announces a {width}x{height} image, more than "
                          f"{len(data)} bytes of PNG can hold; the file is truncated or corrupt")
    try:
        image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise FormatError(f"{where}: corrupt PNG, OpenCV cannot decode it "
                          f"({' '.join(str(exc).split())[-120:]})") from None
    shape = (height, width) if channels[colour] == 1 else (height, width, channels[colour])
    if image is None or image.shape != shape:
        raise FormatError(f"{where}: truncated or corrupt PNG (its {width}x{height} {expected} "
                          "data cannot be decoded)")
    return image
