"""Hand-picked examples for the fast PNG encoder of the dataset writers (``matcher.io.png``).

Property companion: ``test_png_round_trips_through_opencv`` in ``test_io_writers_properties.py``.
"""

from __future__ import annotations

import io
import struct
import zlib

import cv2
import numpy as np
import pytest
from PIL import Image

from matcher.io import png
from matcher.io.png import DEFLATE, encode_png

DEFLATES = ["zlib", "isal", "libdeflate", "stored"]


def _chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    out, pos = [], 8
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])
        assert crc == zlib.crc32(kind + body)
        out.append((kind, body))
        pos += 12 + n
    return out


def _decode(data: bytes) -> np.ndarray:
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    return img[..., ::-1] if img.ndim == 3 else img


@pytest.mark.parametrize("deflate", DEFLATES)
def test_rgb_grey_and_16_bit_images_decode_to_the_same_pixels(deflate):
    rng = np.random.default_rng(0)
    images = [rng.integers(0, 256, (7, 5, 3), dtype=np.uint8),
              rng.integers(0, 256, (4, 9), dtype=np.uint8),
              rng.integers(0, 65536, (6, 3), dtype=np.uint16),
              rng.integers(0, 65536, (2, 2, 3), dtype=np.uint16),
              np.full((1, 1), 200, np.uint8)]
    for img in images:
        data = encode_png(img, deflate=deflate)
        np.testing.assert_array_equal(_decode(data), img)
        if not (img.ndim == 3 and img.dtype == np.uint16):  # Pillow reads 16-bit RGB as 8-bit
            np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(data))), img)


def test_file_structure_and_up_filter():
    img = np.array([[1, 2, 3], [4, 4, 250]], np.uint8)
    chunks = _chunks(encode_png(img, deflate="zlib"))
    assert [k for k, _ in chunks] == [b"IHDR", b"IDAT", b"IEND"]
    assert chunks[0][1] == struct.pack(">IIBBBBB", 3, 2, 8, 0, 0, 0, 0)  # 3x2, 8-bit grey
    raw = zlib.decompress(chunks[1][1])
    # filter byte 2 ("Up") per row; row 0 as is, row 1 minus row 0 modulo 256
    assert raw == bytes([2, 1, 2, 3, 2, 3, 2, 247])
    head = _chunks(encode_png(np.zeros((1, 2, 3), np.uint16)))[0][1]
    assert head == struct.pack(">IIBBBBB", 2, 1, 16, 2, 0, 0, 0)  # 16-bit RGB


def test_stored_is_the_unfiltered_rows_in_stored_blocks():
    # 70,000 bytes of rows: two stored blocks (at most 65,535 bytes each), the last one flagged
    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, (100, 233, 3), dtype=np.uint8)
    idat = _chunks(encode_png(img, deflate="stored"))[1][1]
    rows = np.concatenate([np.zeros((100, 1), np.uint8), img.reshape(100, -1)], axis=1)
    raw = rows.tobytes()  # filter byte 0 ("None") per row
    assert len(raw) == 70_000
    assert idat[:2] == b"\x78\x01" and (idat[0] * 256 + idat[1]) % 31 == 0  # zlib header
    assert idat[2:7] == struct.pack("<BHH", 0, 65535, 0)
    assert idat[7:7 + 65535] == raw[:65535]
    tail = idat[7 + 65535:]
    assert tail[:5] == struct.pack("<BHH", 1, 70_000 - 65535, (70_000 - 65535) ^ 0xFFFF)
    assert tail[5:-4] == raw[65535:]
    assert tail[-4:] == struct.pack(">I", zlib.adler32(raw))
    assert zlib.decompress(idat) == raw
    # a row set of exactly one block's size, and a one-pixel image
    for shape in ((5, 13107), (1, 1)):
        one = rng.integers(0, 256, shape, dtype=np.uint8)
        assert zlib.decompress(_chunks(encode_png(one, deflate="stored"))[1][1]) \
            == np.concatenate([np.zeros((shape[0], 1), np.uint8), one], axis=1).tobytes()
        np.testing.assert_array_equal(_decode(encode_png(one, deflate="stored")), one)


def test_stored_bytes_depend_on_the_pixels_alone():
    img = np.random.default_rng(3).integers(0, 256, (31, 17, 3), dtype=np.uint8)
    data = encode_png(img, deflate="stored")
    # signature 8, IHDR 25, IDAT 12 + zlib (2 + 5 per block + rows + 4), IEND 12
    assert len(data) == 8 + 25 + 12 + 2 + 5 + 31 * (17 * 3 + 1) + 4 + 12
    assert data == encode_png(img[::-1][::-1].copy(), deflate="stored")


def test_sixteen_bit_values_are_big_endian():
    img = np.array([[0x0102, 0xFFFE]], np.uint16)
    raw = zlib.decompress(_chunks(encode_png(img))[1][1])
    assert raw == bytes([2, 0x01, 0x02, 0xFF, 0xFE])


def test_strided_input_gives_the_bytes_of_its_copy():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (10, 12, 3), dtype=np.uint8)
    for view in (img[::-1], img[:, ::2], img[2:7, 3:9]):
        assert encode_png(view) == encode_png(np.ascontiguousarray(view))


def test_chunk_crcs_do_not_depend_on_the_crc_implementation(monkeypatch):
    # ISA-L's CRC-32 where isal is installed, zlib's otherwise: the same file either way (a
    # 960 x 540 colour image: an IDAT long enough for the vectorised paths)
    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, (540, 960, 3), dtype=np.uint8)
    img[100:300] = 7
    data = encode_png(img)
    assert len(_chunks(data)) == 3  # every CRC checked against zlib's
    monkeypatch.setattr(png, "_crc32", zlib.crc32)
    assert encode_png(img) == data


def test_deflate_default_and_fallback(monkeypatch):
    img = np.arange(48, dtype=np.uint8).reshape(4, 4, 3)
    assert DEFLATE in ("isal", "zlib")
    assert encode_png(img) == encode_png(img, deflate=DEFLATE)
    monkeypatch.setattr(png, "_isal_zlib", None)  # isal missing: "isal" falls back to zlib
    assert encode_png(img, deflate="isal") == encode_png(img, deflate="zlib")


def test_grey_images_are_deflated_by_libdeflate():
    import deflate

    mask = np.full((32, 48), 255, np.uint8)
    mask[5:20, 10:14] = 128
    for grey in (mask, mask.astype(np.uint16) * 257):
        png_bytes = encode_png(grey)
        assert png_bytes == encode_png(grey, deflate="libdeflate") != encode_png(grey,
                                                                                  deflate="zlib")
        # the IDAT stream is libdeflate's zlib stream of the "Up"-filtered rows, level 2
        idat = dict(_chunks(png_bytes))[b"IDAT"]
        rows = grey.astype(">u2" if grey.dtype == np.uint16 else np.uint8).view(np.uint8)
        filtered = np.hstack([np.full((32, 1), 2, np.uint8),
                              np.vstack([rows[:1], rows[1:] - rows[:-1]])])
        assert idat == deflate.zlib_compress(filtered.tobytes(), 2)
    colour = np.dstack([mask] * 3)
    assert encode_png(colour) == encode_png(colour, deflate=DEFLATE)


@pytest.mark.parametrize(
    ("image", "error", "match"),
    [
        (np.zeros((2, 2), np.float32), TypeError, "uint8 or uint16"),
        ([[1, 2]], TypeError, "got list"),
        (np.zeros((2, 2, 4), np.uint8), ValueError, r"\(H, W\) or \(H, W, 3\)"),
        (np.zeros((0, 2), np.uint8), ValueError, "non-empty"),
    ],
)
def test_bad_images_are_refused(image, error, match):
    with pytest.raises(error, match=match):
        encode_png(image)


def test_unknown_deflate_is_refused():
    with pytest.raises(ValueError, match="deflate: expected one of 'isal', 'libdeflate', "
                                         "'zlib', 'stored' or None, got 'zstd'"):
        encode_png(np.zeros((2, 2), np.uint8), deflate="zstd")


def test_grey_images_are_one_channel_and_colour_ones_with_equal_channels_pass(tmp_path):
    from stereoforge.errors import FormatError

    mask = np.array([[255, 128, 0]], np.uint8)
    cv2.imwrite(str(tmp_path / "grey.png"), mask)
    cv2.imwrite(str(tmp_path / "grey-as-rgb.png"), np.dstack([mask] * 3))
    for name in ("grey.png", "grey-as-rgb.png"):
        out = png.read_grey_image(tmp_path / name, what="mask")
        assert out.dtype == np.uint8 and out.shape == (1, 3)
        np.testing.assert_array_equal(out, mask)
    colour = np.dstack([mask, np.full_like(mask, 255), mask])  # green where the mask is 0
    cv2.imwrite(str(tmp_path / "colour.png"), colour)
    with pytest.raises(FormatError, match=r"colour\.png: mask must be one channel \(grey\) PNG, "
                                          r"got 3 channels; save it as grey"):
        png.read_grey_image(tmp_path / "colour.png", what="mask", fix="save it as grey")
    cv2.imwrite(str(tmp_path / "deep.png"), mask.astype(np.uint16) * 256)
    with pytest.raises(FormatError, match="obj_map must be an 8-bit PNG, got dtype uint16"):
        png.read_grey_image(tmp_path / "deep.png", what="obj_map")
