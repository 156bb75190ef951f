"""Middlebury optical-flow files (``.flo``): the 2-D correspondence left -> right.

Layout (Baker et al., the Middlebury flow benchmark's ``flowIO.cpp``; see ``docs/formats.md``)::

    "PIEH"          4 bytes: the float 202021.25 in little-endian order (the magic tag)
    <W> <H>         two little-endian int32
    <data>          W * H * 2 little-endian float32 (u, v interleaved), rows TOP to bottom

A pixel ``(x, y)`` of the first image corresponds to ``(x + u, y + v)`` of the second. A value
with ``|u| > 1e9`` or ``|v| > 1e9`` is *unknown* (the benchmark's ``UNKNOWN_FLOW_THRESH``); the
writer stores unknown as ``1e10`` (its ``UNKNOWN_FLOW``). In memory unknown is NaN: the reader
returns NaN for both components of an unknown pixel, and the writer takes NaN (or ``inf``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from matcher.io.atomic import atomic_write_bytes
from stereoforge.errors import FormatError

__all__ = ["FLO_TAG", "FLO_UNKNOWN", "FLO_UNKNOWN_THRESH", "FloError", "encode_flo",
           "decode_flo", "read_flo", "write_flo"]

FLO_TAG = b"PIEH"
#: What the writer stores for an unknown flow (``UNKNOWN_FLOW`` of flowIO.cpp).
FLO_UNKNOWN = 1e10
#: Above this magnitude a stored value is unknown (``UNKNOWN_FLOW_THRESH``).
FLO_UNKNOWN_THRESH = 1e9
_MAX_SIDE = 1 << 20


class FloError(FormatError):
    """A ``.flo`` file is truncated, corrupt or not a ``.flo`` file."""


def encode_flo(flow: np.ndarray) -> bytes:
    """The bytes of a ``.flo`` file of an (H, W, 2) flow; NaN/inf become unknown (1e10).

    Examples
    --------
    >>> f = np.array([[[1.5, -0.25], [np.nan, np.nan]]], np.float32)
    >>> decode_flo(encode_flo(f)).tolist()
    [[[1.5, -0.25], [nan, nan]]]
    """
    if not isinstance(flow, np.ndarray):
        raise TypeError(f"flow: expected a numpy array, got {type(flow).__name__}")
    if flow.ndim != 3 or flow.shape[2] != 2 or flow.shape[0] == 0 or flow.shape[1] == 0:
        raise ValueError(f"flow: expected an (H, W, 2) array, got shape {flow.shape}")
    if flow.dtype.kind not in "fiu" or flow.dtype == np.bool_:
        raise TypeError(f"flow: expected a real array, got dtype {flow.dtype}")
    f = flow.astype("<f4")
    unknown = ~np.isfinite(f).all(axis=2) | (np.abs(f) > FLO_UNKNOWN_THRESH).any(axis=2)
    f[unknown] = FLO_UNKNOWN
    h, w = f.shape[:2]
    return FLO_TAG + np.array([w, h], "<i4").tobytes() + np.ascontiguousarray(f).tobytes()


def decode_flo(data: bytes, *, where: str = ".flo data") -> np.ndarray:
    """(H, W, 2) float32 flow of the bytes of a ``.flo`` file; unknown pixels are NaN."""
    data = bytes(data)
    if data[:4] != FLO_TAG:
        raise FloError(f"{where}: bad magic {data[:4]!r}; expected {FLO_TAG!r} (a Middlebury "
                       ".flo file)")
    if len(data) < 12:
        raise FloError(f"{where}: truncated header ({len(data)} bytes, expected 12)")
    w, h = (int(v) for v in np.frombuffer(data[4:12], "<i4"))
    if not (0 < w <= _MAX_SIDE and 0 < h <= _MAX_SIDE):
        raise FloError(f"{where}: width {w} and height {h} must be in [1, {_MAX_SIDE}]")
    need = 12 + w * h * 8
    if len(data) < need:
        raise FloError(f"{where}: truncated data ({len(data)} bytes, the header announces "
                       f"{need})")
    f = np.frombuffer(data[12:need], "<f4").reshape(h, w, 2).astype(np.float32)
    unknown = (np.abs(f) > FLO_UNKNOWN_THRESH).any(axis=2) | ~np.isfinite(f).all(axis=2)
    f[unknown] = np.nan
    return f


def read_flo(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a ``.flo`` file (:func:`decode_flo`)."""
    from matcher.io.files import read_file

    return decode_flo(read_file(Path(path), what="flow file"), where=str(path))


def write_flo(path: str | os.PathLike[str], flow: np.ndarray, *, fsync: bool = True) -> Path:
    """Write an (H, W, 2) flow as a ``.flo`` file, atomically (:func:`encode_flo`)."""
    return atomic_write_bytes(path, encode_flo(flow), fsync=fsync)
