"""Hand-picked examples for the codecs of the training layouts: CREStereo's and FSD's disparity
PNGs (``matcher.io.crestereo``, ``matcher.io.fsd``), 4:4:4 JPEG (``matcher.io.jpeg``) and the PFM
header the SceneFlow layout needs.

Property companions (``test_io_training_codecs_properties.py``): each ``*_round_trip*``,
``*_refuses*`` and ``*_corrupt*`` test here pairs with the property of the same subject there.
The two readers quoted below are CREStereo's and FoundationStereo's own, copied verbatim.
"""

from __future__ import annotations

import struct
import subprocess
import sys
import zlib

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest

from matcher.io import (
    CRESTEREO_MAX,
    CRESTEREO_SCALE,
    FSD_MAX,
    JPEG_MIN_QUALITY,
    check_crestereo_range,
    check_fsd_range,
    decode_crestereo_disparity,
    decode_fsd_disparity,
    encode_crestereo_disparity,
    encode_fsd_disparity,
    encode_jpeg,
    encode_pfm,
    encode_png,
    read_crestereo_disparity,
    read_fsd_disparity,
)
from stereoforge.errors import FormatError, ParameterError, ParameterTypeError

INF = np.inf


def crestereo_get_disp(path):
    """``CREStereoDataset.get_disp`` of megvii-research/CREStereo ``dataset.py``, verbatim."""
    disp = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    return disp.astype(np.float32) / 32


def depth_uint8_decoding(depth_uint8, scale=1000):
    """``Utils.py`` of NVlabs/FoundationStereo, verbatim (fed ``imageio.imread(...)`` as in
    their ``scripts/vis_dataset.py``)."""
    depth_uint8 = depth_uint8.astype(float)
    out = depth_uint8[..., 0] * 255 * 255 + depth_uint8[..., 1] * 255 + depth_uint8[..., 2]
    return out / float(scale)


def _codes(png: bytes) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    return image[..., ::-1] if image.ndim == 3 else image


def _ihdr(png: bytes) -> tuple[int, int, int, int]:
    assert png[12:16] == b"IHDR"
    return struct.unpack(">IIBB", png[16:26])


# --- CREStereo -------------------------------------------------------------------------------

def test_crestereo_constants():
    assert CRESTEREO_SCALE == 32
    assert CRESTEREO_MAX == 2047.96875 == 65535 / 32


def test_crestereo_round_trip_example():
    disp = np.array([[0.015625001, 1.5, 2.01, 100.0], [INF, np.nan, CRESTEREO_MAX, 2047.98]],
                    np.float64)
    png = encode_crestereo_disparity(disp)
    assert _ihdr(png) == (4, 2, 16, 0)  # 16-bit, one grey channel
    np.testing.assert_array_equal(_codes(png), [[1, 48, 64, 3200], [0, 0, 65535, 65535]])
    out = decode_crestereo_disparity(png)
    assert out.dtype == np.float32 and out.shape == (2, 4)
    np.testing.assert_array_equal(out, np.float32([[1 / 32, 1.5, 2.0, 100.0],
                                                   [INF, INF, CRESTEREO_MAX, CRESTEREO_MAX]]))
    assert np.abs(out[0] - disp[0]).max() <= 1 / 64


def test_crestereo_decodes_as_crestereo_reads(tmp_path):
    disp = np.array([[3.25, INF, 700.03125], [0.5, 1999.0, np.nan]], np.float32)
    path = tmp_path / "000_left.disp.png"
    path.write_bytes(encode_crestereo_disparity(disp))
    theirs = crestereo_get_disp(str(path))
    ours = read_crestereo_disparity(path)
    assert theirs.dtype == ours.dtype == np.float32
    np.testing.assert_array_equal(theirs[np.isfinite(ours)], ours[np.isfinite(ours)])
    np.testing.assert_array_equal(theirs[~np.isfinite(ours)], 0)  # their mask keeps disp > 0
    np.testing.assert_array_equal(np.isinf(ours), ~np.isfinite(disp))


@pytest.mark.parametrize("value, message", [
    (-0.5, "disp: expected disparities >= 0 (inf or NaN where there is no ground truth), got a "
           "smallest value of -0.5 px at row 0, column 1 (1 pixel negative)"),
    (-INF, "got a smallest value of -inf px"),
    (2047.99, "disp: expected disparities <= 2047.96875 px, the most CREStereo's 16-bit PNG "
              "holds (round(d * 32) <= 65535), got a largest value of 2047.99 px at row 0, "
              "column 1 (1 pixel above); lower the baseline"),
    (1 / 64, "disp: expected finite disparities > 0.015625 px (smaller ones round to code 0, "
             "which CREStereo files read as 'no ground truth'), got 0.015625 px at row 0, "
             "column 1 (1 pixel so small); mark pixels without ground truth with inf"),
    (0.0, "got 0.0 px at row 0, column 1"),
])
def test_crestereo_refuses_what_it_cannot_store(value, message):
    disp = np.array([[1.0, value, 2.0]])
    with pytest.raises(ParameterError) as info:
        encode_crestereo_disparity(disp)
    assert message in str(info.value)


def test_crestereo_refusal_names_the_largest_value():
    disp = np.array([[3000.0, 5000.5], [4000.0, 1.0]], np.float32)
    with pytest.raises(ValueError, match=r"largest value of 5000.5 px at row 0, column 1 "
                                         r"\(3 pixels above\)"):
        encode_crestereo_disparity(disp)


@pytest.mark.parametrize("disp, error, message", [
    ([[1.0]], ParameterTypeError, "disp: expected a numpy array, got list"),
    (np.ones((2, 2), np.uint16), ParameterTypeError, "disp: expected a float32 or float64 disparity map"),
    (np.ones((2, 2, 1)), ParameterError, "disp: expected a 2-D (H, W) map"),
    (np.ones((0, 3)), ParameterError, "disp: expected a non-empty (H, W) map"),
])
def test_crestereo_refuses_bad_arrays(disp, error, message):
    with pytest.raises(error, match=message.replace("(", r"\(").replace(")", r"\)")):
        encode_crestereo_disparity(disp)


def test_check_crestereo_range():
    check_crestereo_range(0.015626, CRESTEREO_MAX)
    check_crestereo_range(5, 5)
    with pytest.raises(ParameterError, match=r"^disp_max: expected disparities <= 2047.96875 px"
                                             r".*got 2048.0 px"):
        check_crestereo_range(1.0, 2048.0)
    with pytest.raises(ParameterError, match=r"^disp_min: expected finite disparities > 0.015625 px"
                                             r".*got 0.01 px"):
        check_crestereo_range(0.01, 10.0)
    with pytest.raises(ParameterError, match=r"^disp_min: expected a finite number >= 0.0, got -1.0"):
        check_crestereo_range(-1.0, 10.0)
    with pytest.raises(ParameterError, match=r"^disp_max: expected a finite number >= 10.0, got 5.0; pass"):
        check_crestereo_range(10.0, 5.0)
    with pytest.raises(ParameterTypeError, match="^disp_max: expected a finite number"):
        check_crestereo_range(1.0, "100")


def test_crestereo_decode_refuses_other_pngs():
    cases = [(np.ones((2, 2), np.uint8), "bit depth 8 and PNG colour type 0"),
             (np.ones((2, 2, 3), np.uint16), "bit depth 16 and PNG colour type 2")]
    for image, detail in cases:
        with pytest.raises(FormatError, match=f"^x.png: CREStereo's disparity PNG is 16-bit grey "
                                              f"\\(one channel\\), this one has {detail}$"):
            decode_crestereo_disparity(encode_png(image), path="x.png")


def test_crestereo_corrupt_and_truncated_files_raise_formaterror(tmp_path):
    png = encode_crestereo_disparity(np.full((6, 5), 3.0))
    with pytest.raises(FormatError, match="^CREStereo disparity data: not a PNG file"):
        decode_crestereo_disparity(b"P5\n" + png)
    with pytest.raises(FormatError, match="no 13-byte IHDR chunk"):
        decode_crestereo_disparity(png[:20])
    for cut in (40, len(png) // 2, len(png) - 12, len(png) - 1):
        with pytest.raises(FormatError, match="truncated or corrupt PNG"):
            decode_crestereo_disparity(png[:cut])
    broken = bytearray(png)
    broken[45] ^= 0xFF  # inside the IDAT: its CRC no longer matches
    path = tmp_path / "bad.disp.png"
    path.write_bytes(bytes(broken))
    with pytest.raises(FormatError, match=f"^{path}: "):
        read_crestereo_disparity(path)
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_crestereo_disparity(tmp_path / "missing.png")
    with pytest.raises(TypeError, match="^data: expected the bytes of a PNG file, got str"):
        decode_crestereo_disparity(str(path))


def test_a_huge_header_fails_before_anything_is_allocated():
    ihdr = struct.pack(">IIBBBBB", 60000, 60000, 16, 0, 0, 0, 0)
    idat = zlib.compress(b"\x00" * 1000)
    data = b"\x89PNG\r\n\x1a\n" + b"".join(
        struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        for kind, body in ((b"IHDR", ihdr), (b"IDAT", idat), (b"IEND", b"")))
    with pytest.raises(FormatError, match=f"announces a 60000x60000 image, more than {len(data)} bytes"):
        decode_crestereo_disparity(data)


def test_maps_without_any_ground_truth_decode_despite_their_tiny_files():
    """The bound on the header (deflate expands at most 1032-fold) holds for the most
    compressible real files: a 960 x 540 map without ground truth (all codes 0)."""
    empty = np.full((540, 960), INF, np.float32)
    for encode, decode in ((encode_crestereo_disparity, decode_crestereo_disparity),
                           (encode_fsd_disparity, decode_fsd_disparity)):
        png = encode(empty)
        assert len(png) < 540 * 960 // 100
        np.testing.assert_array_equal(decode(png), empty)


# --- FSD -------------------------------------------------------------------------------------

def test_fsd_constants():
    assert FSD_MAX == 16581.374 == (255**3 - 1) / 1000


def test_fsd_round_trip_example():
    disp = np.array([[1.5, 70.0, 0.0006, INF], [FSD_MAX, 12.3454, np.nan, 255.0]])
    png = encode_fsd_disparity(disp)
    assert _ihdr(png) == (4, 2, 8, 2)  # 8-bit RGB
    np.testing.assert_array_equal(_codes(png), [  # R, G, B: the base-255 digits of round(d * 1000)
        [[0, 5, 225], [1, 19, 130], [0, 0, 1], [0, 0, 0]],
        [[254, 254, 254], [0, 48, 105], [0, 0, 0], [3, 235, 0]]])
    out = decode_fsd_disparity(png)
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out, np.float32([[1.5, 70.0, 0.001, INF], [FSD_MAX, 12.345, INF, 255.0]]))


def test_fsd_decodes_as_foundationstereo_reads(tmp_path):
    disp = np.array([[0.25, INF, 700.031], [12.345, 5000.0, 16000.0]], np.float32)
    path = tmp_path / "0000.png"
    path.write_bytes(encode_fsd_disparity(disp))
    theirs = depth_uint8_decoding(imageio.imread(path))
    ours = read_fsd_disparity(path)
    np.testing.assert_array_equal(theirs.astype(np.float32), np.where(np.isinf(ours), 0, ours))
    np.testing.assert_array_equal(theirs[np.isinf(ours)], 0)
    np.testing.assert_array_equal(np.isinf(ours), np.isinf(disp))
    assert np.abs(theirs - disp)[np.isfinite(disp)].max() <= 0.0005 + 1e-9  # float32 d, exact codes


def test_fsd_decode_takes_rgba_and_digits_of_255_as_their_formula():
    rgba = np.array([[[0, 0, 255, 7], [1, 255, 0, 255], [0, 0, 0, 0]]], np.uint8)
    out = decode_fsd_disparity(encode_png(rgba[..., :3]))
    with_alpha = cv2.imencode(".png", rgba[..., [2, 1, 0, 3]])[1].tobytes()  # BGRA for OpenCV
    np.testing.assert_array_equal(decode_fsd_disparity(with_alpha), out)
    np.testing.assert_array_equal(out, np.float32([[0.255, (65025 + 255 * 255) / 1000, INF]]))


@pytest.mark.parametrize("value, message", [
    (-1e-3, "got a smallest value of -0.001 px at row 0, column 1 (1 pixel negative)"),
    (16581.375, "disp: expected disparities <= 16581.374 px, the most FSD's RGB PNG holds "
                "(round(d * 1000) <= 16581374), got a largest value of 16581.375 px"),
    (0.0005, "disp: expected finite disparities > 0.0005 px (smaller ones round to code 0, which "
             "FSD files read as 'no ground truth'), got 0.0005 px at row 0, column 1"),
])
def test_fsd_refuses_what_it_cannot_store(value, message):
    with pytest.raises(ParameterError) as info:
        encode_fsd_disparity(np.array([[1.0, value]]))
    assert message in str(info.value)


def test_check_fsd_range():
    check_fsd_range(0.0006, FSD_MAX)
    with pytest.raises(ParameterError, match=r"^disp_max: expected disparities <= 16581.374 px"):
        check_fsd_range(1.0, 16581.3751)
    with pytest.raises(ParameterError, match=r"^disp_min: expected finite disparities > 0.0005 px"):
        check_fsd_range(0.0004, 1.0)


def test_fsd_decode_refuses_other_pngs_and_corrupt_files():
    with pytest.raises(FormatError, match=r"^FSD disparity data: FSD's disparity PNG is 8-bit RGB, "
                                          r"this one has bit depth 16 and PNG colour type 0$"):
        decode_fsd_disparity(encode_crestereo_disparity(np.ones((2, 2))))
    png = encode_fsd_disparity(np.full((4, 4), 9.0))
    with pytest.raises(FormatError, match="^d.png: truncated or corrupt PNG"):
        decode_fsd_disparity(png[:-5], path="d.png")


def test_disparity_pngs_are_the_same_bytes_in_another_process():
    """Same map, same bytes: in this process, again, and in a fresh interpreter (the colour PNG
    of FSD is deflated by libdeflate, whose bytes do not depend on the CPU or the process)."""
    code = (
        "import sys, numpy as np\n"
        "from matcher.io import encode_crestereo_disparity, encode_fsd_disparity, encode_jpeg\n"
        "d = np.linspace(0.5, 900.0, 48 * 64).reshape(48, 64)\n"
        "img = (np.arange(48 * 64 * 3) % 251).astype(np.uint8).reshape(48, 64, 3)\n"
        "sys.stdout.buffer.write(encode_crestereo_disparity(d) + b'|' + encode_fsd_disparity(d)"
        " + b'|' + encode_jpeg(img))\n"
    )
    d = np.linspace(0.5, 900.0, 48 * 64).reshape(48, 64)
    img = (np.arange(48 * 64 * 3) % 251).astype(np.uint8).reshape(48, 64, 3)
    here = encode_crestereo_disparity(d) + b"|" + encode_fsd_disparity(d) + b"|" + encode_jpeg(img)
    assert here == encode_crestereo_disparity(d) + b"|" + encode_fsd_disparity(d) + b"|" + encode_jpeg(img)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, check=True)
    assert out.stdout == here


# --- JPEG ------------------------------------------------------------------------------------

def _sof_sampling(jpg: bytes) -> list[int]:
    """The sampling byte of each component of the (single) baseline SOF0 frame."""
    pos = 2
    while pos < len(jpg):
        assert jpg[pos] == 0xFF
        marker, (length,) = jpg[pos + 1], struct.unpack(">H", jpg[pos + 2:pos + 4])
        if marker == 0xC0:
            n = jpg[pos + 9]
            return [jpg[pos + 10 + 3 * k + 1] for k in range(n)]
        assert marker not in (0xC1, 0xC2, 0xDA), f"marker {marker:#x} before SOF0"
        pos += 2 + length
    raise AssertionError("no SOF0 marker")


def _textured(h=48, w=64, seed=1):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.random((h, w, 3)), (0, 0), 1.0) * 255
    img[10:30, 20:40] = (230, 20, 40)  # a saturated block: chroma edges that 4:2:0 would blur
    return np.clip(img, 0, 255).astype(np.uint8)


def test_jpeg_is_baseline_4_4_4_and_close_to_the_image():
    img = _textured()
    for quality in (95, 98, 100):
        jpg = encode_jpeg(img, quality=quality)
        assert jpg[:2] == b"\xff\xd8" and jpg[-2:] == b"\xff\xd9"
        assert _sof_sampling(jpg) == [0x11, 0x11, 0x11]  # 1x1 each: no chroma subsampling
        back = cv2.imdecode(np.frombuffer(jpg, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]  # RGB
        diff = np.abs(back.astype(int) - img)
        assert diff.mean() < {95: 2.5, 98: 1.5, 100: 0.6}[quality], (quality, diff.mean())
    grey = img[..., 0].copy()
    jpg = encode_jpeg(grey)
    assert _sof_sampling(jpg) == [0x11]
    assert cv2.imdecode(np.frombuffer(jpg, np.uint8), cv2.IMREAD_UNCHANGED).shape == grey.shape


def test_jpeg_keeps_colour_edges_sharper_than_4_2_0():
    img = _textured()
    ours = cv2.imdecode(np.frombuffer(encode_jpeg(img), np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
    bgr = np.ascontiguousarray(img[..., ::-1])
    sub = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, 95, cv2.IMWRITE_JPEG_SAMPLING_FACTOR,
                                     cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420])[1]
    theirs = cv2.imdecode(sub, cv2.IMREAD_COLOR)[..., ::-1]
    assert np.abs(ours.astype(int) - img).mean() < np.abs(theirs.astype(int) - img).mean()


@pytest.mark.parametrize("image, kwargs, error, message", [
    (np.zeros((4, 4, 3), np.uint8), {"quality": 94}, ParameterError,
     "quality: expected an integer in [95, 100], got 94; lower qualities blur texture"),
    (np.zeros((4, 4, 3), np.uint8), {"quality": 101}, ParameterError, "got 101"),
    (np.zeros((4, 4, 3), np.uint8), {"quality": 95.0}, ParameterTypeError, "got float 95.0"),
    (np.zeros((4, 4, 3), np.float32), {}, ParameterTypeError,
     "image: expected a uint8 image, got dtype float32; convert with np.clip"),
    (np.zeros((4, 4, 4), np.uint8), {}, ParameterError,
     "image: expected shape (H, W) or (H, W, 3) (RGB), got (4, 4, 4); drop an alpha channel"),
    (np.zeros((0, 4, 3), np.uint8), {}, ParameterError, "image: expected a non-empty image"),
    (np.zeros((1, 65501), np.uint8), {}, ParameterError, "sides <= 65500"),
])
def test_jpeg_refuses_bad_input(image, kwargs, error, message):
    with pytest.raises(error) as info:
        encode_jpeg(image, **kwargs)
    assert message in str(info.value)
    assert JPEG_MIN_QUALITY == 95


# --- PFM for the SceneFlow layout ---------------------------------------------------------

def test_pfm_header_is_exactly_pf_w_h_minus_1_and_nothing_follows_the_data():
    disp = np.array([[1.0, 2.5, INF, 4.0, 5.0], [6.0, 7.0, 8.0, np.nan, 10.0],
                     [11.0, 12.0, 13.0, 14.0, 15.5]], np.float32)
    data = encode_pfm(disp)
    header = b"Pf\n5 3\n-1\n"
    assert data[:len(header)] == header
    assert len(data) == len(header) + 4 * disp.size  # nothing after the data
    body = np.frombuffer(data[len(header):], "<f4").reshape(3, 5)
    np.testing.assert_array_equal(body[::-1].view(np.uint32), disp.view(np.uint32))  # bottom row first
