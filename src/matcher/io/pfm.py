"""Portable Float Map (PFM) files: the float image format of the Middlebury 2014 and
Scene Flow datasets.

Layout (see ``docs/formats.md``)::

    Pf\\n            magic: ``Pf`` grey (1 channel), ``PF`` colour (3 channels, RGB)
    <W> <H>\\n       width and height, positive ASCII decimal integers
    <scale>\\n       non-zero real number; its SIGN gives the byte order of the data
                    (negative: little-endian, positive: big-endian); |scale| is a unit factor
                    that this module reports but never applies
    <data>          W * H * channels IEEE-754 float32 values, rows stored BOTTOM to top,
                    channels interleaved

The header fields may be separated by any ASCII whitespace; exactly one whitespace byte follows
the scale. Bytes after the data are ignored. ``inf`` and NaN are stored bit-exactly.

The reader is hardened against corrupt input: every problem raises :class:`PFMError` (a
:class:`ValueError`) naming the file, and the expected data size is checked against the file size
before anything is allocated.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from matcher.io.atomic import atomic_write_bytes
from matcher.io.files import open_file
from stereoforge.errors import FormatError

__all__ = [
    "PFMError",
    "PFMHeader",
    "decode_pfm",
    "encode_pfm",
    "read_pfm",
    "read_pfm_header",
    "write_pfm",
]

_MAX_HEADER = 256  # bytes; real headers are ~20
_WS = b" \t\n\r\v\f"
_INT = re.compile(rb"[0-9]{1,10}")
_REAL = re.compile(rb"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


class PFMError(FormatError):
    """A PFM file is truncated, corrupt or not a PFM file."""


@dataclass(frozen=True)
class PFMHeader:
    """The parsed header of a PFM file.

    Attributes
    ----------
    width, height : int
        Image size in pixels.
    channels : int
        1 (``Pf``) or 3 (``PF``).
    scale : float
        The scale field as stored (its sign gives the byte order).
    little_endian : bool
        ``scale < 0``.
    data_offset : int
        Byte offset of the first sample.
    """

    width: int
    height: int
    channels: int
    scale: float
    little_endian: bool
    data_offset: int

    @property
    def data_bytes(self) -> int:
        """Number of data bytes the header announces."""
        return self.width * self.height * self.channels * 4


def _parse_header(head: bytes, where: str) -> PFMHeader:
    if len(head) < 2 or head[:2] not in (b"PF", b"Pf"):
        raise PFMError(f"{where}: bad magic {head[:2]!r}; expected b'PF' (colour) or b'Pf' (grey)")
    channels = 3 if head[:2] == b"PF" else 1
    pos = 2
    tokens: list[bytes] = []
    for _ in range(3):
        start = pos
        while pos < len(head) and head[pos] in _WS:
            pos += 1
        if pos == start:
            raise PFMError(f"{where}: truncated or malformed header (expected whitespace at byte {pos})")
        tok_start = pos
        while pos < len(head) and head[pos] not in _WS:
            pos += 1
        if pos == len(head):
            raise PFMError(
                f"{where}: truncated header (no whitespace after field {len(tokens) + 1} "
                f"within the first {_MAX_HEADER} bytes)"
            )
        tokens.append(head[tok_start:pos])
    data_offset = pos + 1  # exactly one whitespace byte after the scale
    names = ("width", "height")
    dims = []
    for name, tok in zip(names, tokens[:2]):
        if not _INT.fullmatch(tok):
            raise PFMError(f"{where}: {name} {tok[:20]!r} is not a decimal integer")
        value = int(tok)
        if value <= 0:
            raise PFMError(f"{where}: {name} must be positive, got {value}")
        dims.append(value)
    if not _REAL.fullmatch(tokens[2]):
        raise PFMError(f"{where}: scale {tokens[2][:20]!r} is not a number")
    scale = float(tokens[2])
    if scale == 0 or not np.isfinite(scale):
        raise PFMError(f"{where}: scale must be a finite non-zero number, got {scale}")
    return PFMHeader(dims[0], dims[1], channels, scale, scale < 0, data_offset)


def read_pfm_header(path: str | os.PathLike[str]) -> PFMHeader:
    """Parse and check the header of a PFM file without reading its data.

    Raises
    ------
    PFMError
        If the header is corrupt or the file is shorter than the header announces.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = write_pfm(f"{d}/a.pfm", np.zeros((2, 3), np.float32))
    ...     read_pfm_header(f"{d}/a.pfm").width
    3
    """
    path = Path(path)
    with open_file(path, what="PFM file", limit=None) as f:
        head = f.read(_MAX_HEADER)
        size = os.fstat(f.fileno()).st_size
    header = _parse_header(head, str(path))
    available = size - header.data_offset
    if available < header.data_bytes:
        raise PFMError(
            f"{path}: data too short for a {header.width}x{header.height}x{header.channels} "
            f"image: header announces {header.data_bytes} bytes, file holds {max(available, 0)}"
        )
    return header


def read_pfm(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a PFM file.

    Parameters
    ----------
    path : str or path-like
        The file.

    Returns
    -------
    (H, W) or (H, W, 3) float32 array
        Native byte order, row 0 at the top (the file's bottom-to-top rows are flipped). The
        scale magnitude is not applied; ``inf``/NaN are preserved.

    Raises
    ------
    PFMError
        If the file is not a valid PFM file (bad magic, malformed or non-positive dimensions,
        zero or non-numeric scale, data shorter than announced).
    OSError
        If the file cannot be opened.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = write_pfm(f"{d}/a.pfm", np.array([[1.0, np.inf]], np.float32))
    ...     read_pfm(f"{d}/a.pfm")
    array([[ 1., inf]], dtype=float32)
    """
    path = Path(path)
    with open_file(path, what="PFM file", limit=None) as f:
        head = f.read(_MAX_HEADER)
        size = os.fstat(f.fileno()).st_size
        header = _parse_header(head, str(path))
        if size - header.data_offset < header.data_bytes:
            raise PFMError(
                f"{path}: data too short for a {header.width}x{header.height}x{header.channels} "
                f"image: header announces {header.data_bytes} bytes, file holds "
                f"{max(size - header.data_offset, 0)}"
            )
        f.seek(header.data_offset)
        raw = f.read(header.data_bytes)
    if len(raw) < header.data_bytes:  # the file shrank while we read it
        raise PFMError(f"{path}: data too short ({len(raw)} of {header.data_bytes} bytes)")
    return _samples(raw, header)


def decode_pfm(data: bytes, *, where: str = "PFM data") -> np.ndarray:
    """Decode the bytes of a PFM file (the inverse of :func:`encode_pfm`).

    Parameters
    ----------
    data : bytes or bytes-like
        A whole PFM file; bytes after the samples are ignored.
    where : str, default "PFM data"
        Name of the source in error messages (e.g. a file or archive member).

    Returns
    -------
    (H, W) or (H, W, 3) float32 array
        As :func:`read_pfm` returns it.

    Raises
    ------
    PFMError
        If the bytes are not a valid PFM file (as for :func:`read_pfm`).

    Examples
    --------
    >>> import numpy as np
    >>> decode_pfm(encode_pfm(np.array([[1.0, np.inf]], np.float32)))
    array([[ 1., inf]], dtype=float32)
    """
    if not isinstance(data, (bytes, bytearray, memoryview)):
        raise TypeError(f"data: expected the bytes of a PFM file, got {type(data).__name__}")
    data = bytes(data)
    header = _parse_header(data[:_MAX_HEADER], where)
    available = len(data) - header.data_offset
    if available < header.data_bytes:
        raise PFMError(
            f"{where}: data too short for a {header.width}x{header.height}x{header.channels} "
            f"image: header announces {header.data_bytes} bytes, the data holds "
            f"{max(available, 0)}"
        )
    return _samples(data[header.data_offset : header.data_offset + header.data_bytes], header)


def _samples(raw: bytes, header: PFMHeader) -> np.ndarray:
    """The image from exactly ``header.data_bytes`` sample bytes: native float32, top row first."""
    dtype = np.dtype("<f4" if header.little_endian else ">f4")
    shape = (header.height, header.width) + ((3,) if header.channels == 3 else ())
    data = np.frombuffer(raw, dtype=dtype).reshape(shape)[::-1]
    return data.astype(np.float32)  # native order, C-contiguous, writable copy


def encode_pfm(array: np.ndarray, *, scale: float = -1.0) -> bytes:
    """Encode an array as the bytes of a PFM file (see :func:`write_pfm`).

    Examples
    --------
    >>> import numpy as np
    >>> encode_pfm(np.zeros((1, 1), np.float32))
    b'Pf\\n1 1\\n-1\\n\\x00\\x00\\x00\\x00'
    """
    if not isinstance(array, np.ndarray):
        raise TypeError(f"array: expected a numpy array, got {type(array).__name__}")
    if array.dtype == np.bool_ or array.dtype.kind not in "uif":
        raise TypeError(
            f"array: expected a real numeric array, got dtype {array.dtype}; "
            "convert with .astype(np.float32)"
        )
    if array.ndim == 3 and array.shape[2] == 1:
        array = array[:, :, 0]
    if not (array.ndim == 2 or (array.ndim == 3 and array.shape[2] == 3)):
        raise ValueError(f"array: expected shape (H, W) or (H, W, 3), got {array.shape}")
    if array.shape[0] == 0 or array.shape[1] == 0:
        raise ValueError(f"array: expected a non-empty array, got shape {array.shape}")
    if isinstance(scale, (bool, np.bool_)) or not isinstance(scale, (int, float, np.number)):
        raise TypeError(f"scale: expected a real number, got {type(scale).__name__}")
    scale = float(scale)
    if scale == 0 or not np.isfinite(scale):
        raise ValueError(
            f"scale: expected a finite non-zero number (negative: little-endian), got {scale}"
        )
    magic = b"PF" if array.ndim == 3 else b"Pf"
    h, w = array.shape[:2]
    dtype = np.dtype("<f4" if scale < 0 else ">f4")
    data = np.ascontiguousarray(array, dtype=dtype)  # no copy of a float32 map of that order
    scale_text = np.format_float_positional(scale, trim="-").encode("ascii")
    # the rows bottom to top, joined once with the header: one copy of the samples (flipping,
    # then tobytes, then a concatenation made three)
    return b"".join((b"%s\n%d %d\n%s\n" % (magic, w, h, scale_text),
                     *map(memoryview, data[::-1])))


def write_pfm(path: str | os.PathLike[str], array: np.ndarray, *, scale: float = -1.0,
              fsync: bool = True) -> Path:
    """Write an array as a PFM file.

    Parameters
    ----------
    path : str or path-like
        Destination, in an existing directory; replaced atomically (a temporary file, then a
        rename: see :mod:`matcher.io.atomic`), so a failure (disk full) leaves no truncated
        file and a previous file intact.
    array : (H, W), (H, W, 1) or (H, W, 3) real array
        Converted to float32 (``Pf`` for one channel, ``PF`` for three). ``inf``/NaN are kept.
    scale : float, default -1.0
        Stored scale field. Its sign chooses the byte order: negative (the default, as in the
        Middlebury 2014 files) is little-endian, positive is big-endian. Its magnitude is
        written as given and never applied to the data.
    fsync : bool, default True
        Flush the file to disk before the rename (see :func:`atomic_write_bytes`).

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = write_pfm(f"{d}/c.pfm", np.ones((2, 2, 3)), scale=1.0)  # big-endian colour
    ...     read_pfm(p).shape
    (2, 2, 3)
    """
    return atomic_write_bytes(path, encode_pfm(array, scale=scale), fsync=fsync)
