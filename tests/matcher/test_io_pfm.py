"""Hand-picked PFM examples: exact bytes, byte orders, row order, corrupt files."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from matcher.io import PFMError, decode_pfm, encode_pfm, read_pfm, read_pfm_header, write_pfm


def test_grey_little_endian_exact_bytes(tmp_path):
    a = np.array([[1.0, 2.0], [3.0, 4.0]], np.float32)
    path = write_pfm(tmp_path / "a.pfm", a)
    # rows stored bottom to top: row 1 first
    assert path.read_bytes() == b"Pf\n2 2\n-1\n" + struct.pack("<4f", 3, 4, 1, 2)
    out = read_pfm(path)
    assert out.dtype == np.float32 and out.dtype.isnative
    np.testing.assert_array_equal(out, a)


def test_colour_big_endian_exact_bytes(tmp_path):
    a = np.arange(12, dtype=np.float32).reshape(2, 2, 3)
    path = write_pfm(tmp_path / "c.pfm", a, scale=1.0)
    expected = b"PF\n2 2\n1\n" + struct.pack(">12f", *a[1].ravel(), *a[0].ravel())
    assert path.read_bytes() == expected
    np.testing.assert_array_equal(read_pfm(path), a)
    header = read_pfm_header(path)
    assert (header.width, header.height, header.channels, header.little_endian) == (2, 2, 3, False)


@pytest.mark.parametrize("scale", [-1.0, 2.0])
def test_any_layout_and_dtype_gives_the_bytes_of_its_flipped_float32_copy(scale):
    rng = np.random.default_rng(3)
    grey = rng.standard_normal((5, 7)) * 100
    grey[1, 2], grey[3, 4] = np.inf, np.nan
    order = "<f4" if scale < 0 else ">f4"
    for a in (grey, grey[::-1], grey[:, ::2], np.asfortranarray(grey), grey.astype(">f4"),
              grey.astype(np.float32), np.arange(35, dtype=np.int16).reshape(5, 7),
              np.dstack([grey, -grey, grey / 3])[:, ::-1]):
        h, w = a.shape[:2]
        reference = np.flipud(a).astype(order).tobytes()
        head = b"%s\n%d %d\n%s\n" % (b"PF" if a.ndim == 3 else b"Pf", w, h,
                                        b"-1" if scale < 0 else b"2")
        assert encode_pfm(a, scale=scale) == head + reference


def test_reads_foreign_header_spacing_and_scale(tmp_path):
    # the same data with a Middlebury-style "-1.000000" scale and spaces instead of newlines
    data = struct.pack("<3f", 1.5, np.inf, np.nan)
    path = tmp_path / "m.pfm"
    path.write_bytes(b"Pf 3 1 -1.000000\n" + data)
    out = read_pfm(path)
    assert out[0, 0] == 1.5 and np.isposinf(out[0, 1]) and np.isnan(out[0, 2])
    assert read_pfm_header(path).scale == -1.0


def test_scale_magnitude_is_not_applied(tmp_path):
    path = write_pfm(tmp_path / "s.pfm", np.full((1, 1), 2.0), scale=-0.5)
    assert read_pfm(path)[0, 0] == 2.0
    assert read_pfm_header(path).scale == -0.5


def test_trailing_bytes_are_ignored(tmp_path):
    path = tmp_path / "t.pfm"
    path.write_bytes(encode_pfm(np.ones((1, 2))) + b"\n")
    np.testing.assert_array_equal(read_pfm(path), np.ones((1, 2), np.float32))


def test_single_channel_3d_input_is_grey(tmp_path):
    path = write_pfm(tmp_path / "g.pfm", np.zeros((2, 3, 1)))
    assert path.read_bytes().startswith(b"Pf\n3 2\n")


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"", "bad magic"),
        (b"P6\n2 2\n255\n", "bad magic"),
        (b"PF", "truncated"),
        (b"Pf\n2 x\n-1\n" + bytes(16), "height"),
        (b"Pf\n2.0 2\n-1\n" + bytes(16), "width"),
        (b"Pf\n0 2\n-1\n", "width must be positive"),
        (b"Pf\n-2 2\n-1\n" + bytes(16), "width"),
        (b"Pf\n2 2\n0\n" + bytes(16), "non-zero"),
        (b"Pf\n2 2\n0.0\n" + bytes(16), "non-zero"),
        (b"Pf\n2 2\nabc\n" + bytes(16), "not a number"),
        (b"Pf\n2 2\nnan\n" + bytes(16), "not a number"),
        (b"Pf\n2 2\n1e999\n" + bytes(16), "finite"),
        (b"Pf\n2 2\n-1\n" + bytes(15), "too short"),
        (b"PF\n2 2\n-1\n" + bytes(16), "too short"),
        (b"Pf\n2 2 -1", "truncated"),
        (b"Pf\n" + b" " * 300 + b"1 1\n-1\n" + bytes(4), "truncated"),
    ],
)
def test_corrupt_files_raise_pfmerror_naming_the_file(tmp_path, content, message):
    path = tmp_path / "bad.pfm"
    path.write_bytes(content)
    with pytest.raises(PFMError, match=message) as info:
        read_pfm(path)
    assert str(path) in str(info.value)
    assert isinstance(info.value, ValueError)


def test_decode_pfm_reads_bytes_as_read_pfm_reads_files():
    a = np.array([[1.0, np.inf], [-0.0, 3.5]], np.float32)
    out = decode_pfm(encode_pfm(a, scale=1.0) + b"trailing")
    assert out.dtype == np.float32 and out.dtype.isnative and out.flags.writeable
    np.testing.assert_array_equal(out, a)
    with pytest.raises(PFMError, match=r"member\.pfm: data too short .* the data holds 15"):
        decode_pfm(b"Pf\n2 2\n-1\n" + bytes(15), where="member.pfm")
    with pytest.raises(PFMError, match="PFM data: bad magic"):
        decode_pfm(b"P6\n2 2\n255\n")
    with pytest.raises(TypeError, match="data: expected the bytes of a PFM file"):
        decode_pfm("Pf\n1 1\n-1\n")


def test_huge_dimensions_fail_before_allocating(tmp_path):
    path = tmp_path / "huge.pfm"
    path.write_bytes(b"PF\n9999999999 9999999999\n-1\n" + bytes(64))
    with pytest.raises(PFMError, match=r"header announces 1199999999760000000012 bytes, file holds 64"):
        read_pfm(path)


def test_missing_file_is_oserror(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_pfm(tmp_path / "nope.pfm")


@pytest.mark.parametrize(
    ("array", "kwargs", "error", "message"),
    [
        (np.zeros((2, 2), bool), {}, TypeError, "real numeric"),
        ([[1.0]], {}, TypeError, "numpy array"),
        (np.zeros((2, 2, 2)), {}, ValueError, r"\(H, W\) or \(H, W, 3\)"),
        (np.zeros((0, 2)), {}, ValueError, "non-empty"),
        (np.zeros((2, 2)), {"scale": 0.0}, ValueError, "non-zero"),
        (np.zeros((2, 2)), {"scale": float("inf")}, ValueError, "finite"),
        (np.zeros((2, 2)), {"scale": "1"}, TypeError, "scale"),
    ],
)
def test_write_rejects_bad_input(tmp_path, array, kwargs, error, message):
    with pytest.raises(error, match=message):
        write_pfm(tmp_path / "x.pfm", array, **kwargs)
    assert not (tmp_path / "x.pfm").exists()
