"""PNG files: 8-bit images and integer-coded disparity maps, read with OpenCV and written
with a fast encoder of our own.

Disparity files use three encodings (see ``docs/formats.md``); :func:`read_disparity` reads
all three:

* PFM: float32 disparity in pixels, ``inf`` where there is no ground truth (Middlebury 2014;
  read by :func:`matcher.io.pfm.read_pfm`).
* 8-bit PNG: ``value / divisor`` pixels, ``0`` = unknown (Middlebury 2005/2006: divisor 1, 2 or
  3 for the full, half and third size).
* 16-bit PNG: ``value / 256`` pixels, ``0`` = invalid (KITTI 2012/2015).

Every reader returns ``inf`` where the file says "no ground truth", never 0.

**Writing.** A dataset pair holds two colour PNGs; with OpenCV's encoder (libpng + zlib level 1)
they cost ~10-15 ms each at 640 x 480, more than any other part of writing. :func:`encode_png`
writes the same kind of file (8- or 16-bit grey or RGB, no interlace) in one pass:

- every row gets PNG's "Up" filter (difference to the row above, computed with numpy), which
  on rendered images compresses as well as libpng's adaptive choice;
- the filtered rows of a **colour** image are deflated by ISA-L (the ``isal`` package, level 1;
  zlib level 1 if it is missing): ~4x faster than zlib, and as small or smaller (measured on
  640 x 480 pairs: smooth renders ~270 KB instead of ~500 KB from libpng, noisy ones ~630 KB
  either way; ~2-4 ms per colour image instead of ~10-17 ms; at 960 x 540 ~4 ms, against
  ~11 ms with libdeflate);
- those of a **grey** image (occlusion, highlight and label masks, KITTI's 16-bit
  disparities) by libdeflate (the ``deflate`` package, level 2), whose output depends only on
  its version, not on the CPU or the process: ISA-L's bytes for the same grey image were seen
  to differ between processes of one machine (three KITTI disparity maps of concurrent runs,
  the pixels identical; a mask written by the main process and by a worker, its disparities
  and pixel counts identical); the cause is not known, and it did not happen on another
  machine. On a 960 x 540 mask
  libdeflate takes ~0.6 ms (ISA-L ~0.1 ms) and writes ~5 KB instead of ~7 KB;
- ``deflate="stored"`` (an option, for colour images where writing speed matters more than
  size): rows unfiltered, the zlib stream made of deflate's *stored* blocks (no compression,
  the format's own mode, which every inflater reads): ~0.5 ms per 960 x 540 colour image
  instead of ISA-L's ~5.5 (in a dataset worker, whose allocations come from its heap), files
  ~1.5x larger, and bytes that depend on the pixels alone (no library, version or CPU);
- the stream goes into a single ``IDAT`` chunk.

Decoders see ordinary PNGs; the *pixels* never depend on the deflate library, but the file
bytes do (:func:`deflate_for` names the one an image gets), so a dataset made on a machine with
``isal`` and resumed on one without holds valid colour PNGs of two byte encodings; ``stereoforge
dataset --compare A B`` tells such encoding differences from differences of content.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from matcher._validation import check_choice, check_positive
from matcher.io.files import read_file
from matcher.io.pfm import read_pfm
from stereoforge.errors import FormatError, ParameterError

import deflate as _libdeflate

try:  # optional accelerator: pip install isal
    from isal import isal_zlib as _isal_zlib
except ImportError:  # pragma: no cover - depends on the environment
    _isal_zlib = None

__all__ = [
    "DEFLATE",
    "DEFLATES",
    "GREY_DEFLATE",
    "KITTI_DIVISOR",
    "check_deflate",
    "decode_disparity_png",
    "deflate_for",
    "encode_png",
    "read_disparity",
    "read_grey_image",
    "read_image",
]

#: The divisor of KITTI's 16-bit disparity PNGs.
KITTI_DIVISOR = 256.0

#: The deflate implementations :func:`encode_png` accepts (``"stored"``: no compression).
DEFLATES = ("isal", "libdeflate", "zlib", "stored")
#: The deflate implementation :func:`encode_png` uses here for colour images: ``"isal"``, or
#: ``"zlib"`` where the ``isal`` package is missing.
DEFLATE = "zlib" if _isal_zlib is None else "isal"
#: The deflate implementation of grey images: libdeflate, whose bytes depend on its version only.
GREY_DEFLATE = "libdeflate"

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_MAX_PIXELS = 2**30  # OpenCV's CV_IO_MAX_IMAGE_PIXELS default
_FILTER_NONE, _FILTER_UP = 0, 2
_STORED_BLOCK = 65535  # the largest stored block deflate allows
_LEVEL = 1  # ISA-L levels are 0..3, zlib's 0..9: level 1 is "fast" in both
_LIBDEFLATE_LEVEL = 2  # faster than its level 1 on grey masks and disparities, and smaller
#: The chunks' CRC-32 (the same numbers either way): ISA-L's is ~10x faster than zlib's, which
#: cost ~0.2 ms per 960 x 540 colour ``IDAT``.
_crc32 = zlib.crc32 if _isal_zlib is None else _isal_zlib.crc32
_adler32 = zlib.adler32 if _isal_zlib is None else _isal_zlib.adler32


def _imread(path: Path, flags: int) -> np.ndarray:
    # read + imdecode handles non-ASCII paths, which cv2.imread does not on every platform, and
    # refuses a FIFO, a device or a huge file before anything is read (matcher.io.files)
    data = np.frombuffer(read_file(path, what="image"), dtype=np.uint8)
    _check_structure(data, path)  # what would make libpng or libjpeg speak on stderr
    try:
        image = cv2.imdecode(data, flags) if data.size else None
    except cv2.error as exc:  # e.g. a header announcing more pixels than OpenCV allows (2**30)
        size = _png_size(data)
        if size and size[0] * size[1] > _MAX_PIXELS:
            raise FormatError(f"{path}: the header announces a {size[0]}x{size[1]} image, more "
                              f"than the {_MAX_PIXELS} pixels OpenCV decodes; check the "
                              "file") from None
        raise FormatError(f"{path}: corrupt image, OpenCV cannot decode it "
                          f"({' '.join(str(exc).split())[-120:]})") from None
    if image is None:
        raise FormatError(f"{path}: not an image OpenCV can decode (corrupt or unsupported format)")
    return image


#: Bytes a deflate stream can expand to per byte, at most (deflate's own bound is 1032:1).
_MAX_INFLATE = 1040
_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}  # PNG colour type -> samples per pixel


def _check_structure(data: np.ndarray, path: Path) -> None:
    """Refuse a PNG or JPEG whose structure is broken before a decoder sees it (their
    libraries print their own complaint on stderr, beside ours): a PNG whose chunks are cut or
    fail their CRC, that has no IEND, or whose image data is too short for the size its header
    announces; a JPEG without its end marker (cut)."""
    raw = data.tobytes() if data.size < 8 or data[:8].tobytes() == _SIGNATURE else None
    if raw is None:
        if data.size >= 2 and data[0] == 0xFF and data[1] == 0xD8:  # a JPEG
            if data.tobytes().rfind(b"\xff\xd9") < 2:
                raise FormatError(f"{path}: a JPEG without its end (cut, or damaged); copy the "
                                  "file again")
        return
    if len(raw) < 8:
        return  # not an image at all: the decoder's one-line refusal below
    pos, ihdr, idat, end = 8, None, 0, False
    while pos + 12 <= len(raw):
        length, kind = struct.unpack(">I4s", raw[pos:pos + 8])
        stop = pos + 12 + length
        if stop > len(raw):
            break
        if zlib.crc32(raw[pos + 4:stop - 4]) != struct.unpack(">I", raw[stop - 4:stop])[0]:
            raise FormatError(f"{path}: PNG chunk {kind!r} at byte {pos} fails its CRC "
                              "(damaged); copy the file again")
        if kind == b"IHDR" and length >= 13:
            ihdr = struct.unpack(">IIBB", raw[pos + 8:pos + 18])
        elif kind == b"IDAT":
            idat += length
        elif kind == b"IEND":
            end = True
            break
        pos = stop
    if not end:
        raise FormatError(f"{path}: a PNG cut short ({len(raw):,} bytes: its chunks stop at byte "
                          f"{pos}, before the IEND chunk); copy the file again")
    if ihdr is None:
        raise FormatError(f"{path}: a PNG without its IHDR header; copy the file again")
    width, height, depth, colour = ihdr
    row = 1 + -(-width * _CHANNELS.get(colour, 4) * max(depth, 1) // 8)
    if width == 0 or height == 0 or height * row > _MAX_INFLATE * idat + 1024:
        raise FormatError(f"{path}: the PNG header announces {width}x{height} pixels, which its "
                          f"{idat:,} bytes of image data cannot hold (damaged or forged); copy "
                          "the file again")


def _png_size(data: np.ndarray) -> tuple[int, int] | None:
    """(width, height) from a PNG's IHDR, if ``data`` starts like a PNG."""
    head = data[:24].tobytes()
    if len(head) == 24 and head[:8] == _SIGNATURE and head[12:16] == b"IHDR":
        return struct.unpack(">II", head[16:24])
    return None


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
        raise FormatError(
            f"{path}: expected an 8-bit image, got dtype {image.dtype}; "
            "for 16-bit disparity maps use read_disparity"
        )
    if image.ndim == 3:
        if image.shape[2] == 4:
            return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
        return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    return image


def read_grey_image(path: str | os.PathLike[str], *, what: str = "image",
                    fix: str | None = None) -> np.ndarray:
    """Read an 8-bit one-channel image: a mask, an object map, a label image.

    A colour file whose channels are all equal (a grey image saved as RGB) is accepted as grey;
    one with different channels is refused, not read by its first channel (a colour-coded mask
    would be taken for one of its channels without a word).

    Parameters
    ----------
    path : str or path-like
    what : str
        What the image is, for the message (``"mask"``).
    fix : str, optional
        Appended to the message of a colour file.

    Returns
    -------
    (H, W) uint8 array

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    FormatError
        If OpenCV cannot decode it, it is not 8-bit, or it has channels that differ.

    Examples
    --------
    >>> import tempfile, cv2, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     _ = cv2.imwrite(f"{d}/m.png", np.array([[[0, 255, 0]]], np.uint8))
    ...     read_grey_image(f"{d}/m.png", what="mask")
    Traceback (most recent call last):
    ...
    stereoforge.errors.FormatError: .../m.png: mask must be one channel (grey) PNG, got 3 channels
    """
    path = Path(path)
    image = _imread(path, cv2.IMREAD_UNCHANGED)
    if image.dtype != np.uint8:
        raise FormatError(f"{path}: {what} must be an 8-bit PNG, got dtype {image.dtype}")
    if image.ndim == 3:
        if not (image == image[:, :, :1]).all():
            tail = f"; {fix}" if fix else ""
            raise FormatError(f"{path}: {what} must be one channel (grey) PNG, got "
                              f"{image.shape[2]} channels{tail}")
        image = np.ascontiguousarray(image[:, :, 0])
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
        raise FormatError(
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
            raise ParameterError(f"divisor: a PFM file stores pixels directly, got divisor={divisor}; pass None")
        disp = read_pfm(path)
        if disp.ndim != 2:
            raise FormatError(f"{path}: expected a grey (Pf) disparity PFM, got shape {disp.shape}")
        return disp
    raw = _imread(path, cv2.IMREAD_UNCHANGED)
    if raw.ndim == 3:
        if not (raw == raw[:, :, :1]).all():
            raise FormatError(f"{path}: a disparity PNG must be single-channel, got {raw.shape[2]} distinct channels")
        raw = np.ascontiguousarray(raw[:, :, 0])
    if divisor is None:
        if raw.dtype != np.uint16:
            raise ParameterError(
                f"divisor: required for the 8-bit disparity PNG {path} (Middlebury: 3 for the "
                "third size, 2 for half, 1 for full)"
            )
        divisor = KITTI_DIVISOR
    return decode_disparity_png(raw, divisor=divisor, where=str(path))


def deflate_for(image: np.ndarray) -> str:
    """The deflate implementation :func:`encode_png` gives ``image`` by default: libdeflate
    (:data:`GREY_DEFLATE`) for a grey ``(H, W)`` image, :data:`DEFLATE` for colour.

    Examples
    --------
    >>> deflate_for(np.zeros((2, 2), np.uint8))
    'libdeflate'
    >>> deflate_for(np.zeros((2, 2, 3), np.uint8)) == DEFLATE
    True
    """
    return GREY_DEFLATE if np.ndim(image) == 2 else DEFLATE


def _stored_zlib(data: memoryview) -> bytes:
    """A zlib stream (RFC 1950) of deflate's stored blocks (RFC 1951, section 3.2.4): the
    data as it is, in blocks of at most 65,535 bytes, each behind its 5-byte header."""
    n = len(data)
    parts: list[bytes | memoryview] = [b"\x78\x01"]  # deflate, 32 KB window, no dictionary
    for start in range(0, max(n, 1), _STORED_BLOCK):
        size = min(_STORED_BLOCK, n - start)
        last = start + _STORED_BLOCK >= n
        parts += [struct.pack("<BHH", last, size, size ^ 0xFFFF), data[start:start + size]]
    parts.append(struct.pack(">I", _adler32(data)))
    return b"".join(parts)


def check_deflate(value: object, name: str = "deflate") -> str:
    """``value`` if it names one of :data:`DEFLATES`, else a ``ParameterError`` naming ``name``
    (the writers' ``image_deflate``, a dataset's key, a bench option).

    Examples
    --------
    >>> check_deflate("stored", "image_deflate")
    'stored'
    >>> check_deflate("gzip", "image_deflate")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: image_deflate: expected one of ['isal', 'libdeflate', 'zlib', 'stored'], got 'gzip'
    """
    return check_choice(value, name, DEFLATES)


def _deflater(name: str) -> Callable[[memoryview], bytes]:
    if name == "stored":
        return _stored_zlib
    if name == "libdeflate":
        return lambda data: _libdeflate.zlib_compress(data, _LIBDEFLATE_LEVEL)
    if name == "isal" and _isal_zlib is not None:
        return lambda data: _isal_zlib.compress(data, _LEVEL)
    return lambda data: zlib.compress(data, _LEVEL)


def _chunk(kind: bytes, data: bytes) -> tuple[bytes, bytes, bytes, bytes]:
    """The parts of a chunk (length, type, data, CRC), joined once with the whole file: a
    concatenation here would copy a colour image's ~1 MB ``IDAT`` twice more."""
    crc = _crc32(data, _crc32(kind))
    return struct.pack(">I", len(data)), kind, data, struct.pack(">I", crc)


def encode_png(image: np.ndarray, *, deflate: str | None = None) -> bytes:
    """Encode an image as PNG bytes (lossless), fast.

    Parameters
    ----------
    image : (H, W) uint8/uint16 array or (H, W, 3) uint8/uint16 array (RGB order)
        Any strides; 16-bit values are stored big-endian as PNG requires.
    deflate : {"isal", "libdeflate", "zlib", "stored"}, optional
        Deflate implementation; default :func:`deflate_for` the image: libdeflate for grey
        images (bytes independent of the CPU), :data:`DEFLATE` for colour (ISA-L if installed,
        else zlib). ``"isal"`` without the package falls back to zlib. ``"stored"``: no
        compression (unfiltered rows in stored blocks; bytes fixed by the pixels alone).

    Returns
    -------
    bytes
        A PNG file: signature, ``IHDR``, one ``IDAT`` ("Up"-filtered rows; unfiltered with
        ``"stored"``), ``IEND``.

    Examples
    --------
    >>> import cv2
    >>> img = np.array([[[255, 0, 0], [0, 9, 200]]], np.uint8)
    >>> png = encode_png(img)
    >>> png[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
    True
    >>> cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)[..., ::-1].tolist()
    [[[255, 0, 0], [0, 9, 200]]]
    >>> stored = encode_png(img, deflate="stored")
    >>> cv2.imdecode(np.frombuffer(stored, np.uint8), cv2.IMREAD_UNCHANGED)[..., ::-1].tolist()
    [[[255, 0, 0], [0, 9, 200]]]
    """
    if not isinstance(image, np.ndarray) or image.dtype not in (np.uint8, np.uint16):
        got = f"dtype {image.dtype}" if isinstance(image, np.ndarray) else type(image).__name__
        raise TypeError(f"image: expected a uint8 or uint16 array, got {got}")
    if not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise ValueError(f"image: expected shape (H, W) or (H, W, 3), got {image.shape}")
    h, w = image.shape[:2]
    if h == 0 or w == 0 or h >= 2**31 or w >= 2**31:
        raise ValueError(f"image: expected a non-empty image with sides < 2**31, got shape "
                         f"{image.shape}")
    if deflate is not None and deflate not in DEFLATES:
        raise ValueError(f"deflate: expected one of {', '.join(map(repr, DEFLATES))} or None, "
                         f"got {deflate!r}")
    dtype = np.dtype(">u2") if image.dtype == np.uint16 else np.dtype(np.uint8)
    rows = np.ascontiguousarray(image, dtype=dtype).reshape(h, -1).view(np.uint8)
    name = deflate or deflate_for(image)
    filtered = np.empty((h, rows.shape[1] + 1), np.uint8)
    if name == "stored":  # a filter only helps compression
        filtered[:, 0] = _FILTER_NONE
        filtered[:, 1:] = rows
    else:
        filtered[:, 0] = _FILTER_UP
        filtered[0, 1:] = rows[0]
        np.subtract(rows[1:], rows[:-1], out=filtered[1:, 1:])  # modulo 256, as PNG defines it
    idat = _deflater(name)(memoryview(filtered).cast("B"))
    colour_type = 0 if image.ndim == 2 else 2
    ihdr = struct.pack(">IIBBBBB", w, h, 8 * dtype.itemsize, colour_type, 0, 0, 0)
    return b"".join((_SIGNATURE, *_chunk(b"IHDR", ihdr), *_chunk(b"IDAT", idat),
                     *_chunk(b"IEND", b"")))
