"""Image/disparity readers, calib.txt, and the dataset loaders (hand-made files and real data)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from matcher.io import (
    encode_png,
    format_calib,
    find_middlebury_2005_divisor,
    infer_middlebury_2005_divisor,
    load_kitti_2015,
    load_middlebury_2005,
    load_middlebury_2014,
    parse_calib,
    read_calib,
    read_disparity,
    read_image,
    write_pfm,
)
from matcher.io.middlebury import divisor_of_shape

SCENES = ("Moebius", "Reindeer", "Flowerpots", "Cloth2", "Midd1", "Baby1")

# --- read_image -------------------------------------------------------------------------------


def test_read_image_returns_rgb(tmp_path):
    bgr = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255]]], np.uint8)
    cv2.imwrite(str(tmp_path / "a.png"), bgr)
    np.testing.assert_array_equal(read_image(tmp_path / "a.png"), bgr[:, :, ::-1])


def test_read_image_grey_and_alpha(tmp_path):
    cv2.imwrite(str(tmp_path / "g.png"), np.array([[7, 9]], np.uint8))
    assert read_image(tmp_path / "g.png").tolist() == [[7, 9]]
    cv2.imwrite(str(tmp_path / "a.png"), np.array([[[1, 2, 3, 4]]], np.uint8))  # BGRA
    assert read_image(tmp_path / "a.png").tolist() == [[[3, 2, 1]]]


def test_encode_png_round_trips_rgb_and_uint16(tmp_path):
    rgb = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    (tmp_path / "c.png").write_bytes(encode_png(rgb))
    np.testing.assert_array_equal(read_image(tmp_path / "c.png"), rgb)
    codes = np.array([[0, 1, 65535]], np.uint16)
    (tmp_path / "d.png").write_bytes(encode_png(codes))
    np.testing.assert_array_equal(cv2.imread(str(tmp_path / "d.png"), cv2.IMREAD_UNCHANGED), codes)


def test_read_image_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_image(tmp_path / "missing.png")
    (tmp_path / "junk.png").write_bytes(b"not an image at all")
    with pytest.raises(ValueError, match="OpenCV can decode"):
        read_image(tmp_path / "junk.png")
    (tmp_path / "empty.png").write_bytes(b"")
    with pytest.raises(ValueError, match="OpenCV can decode"):
        read_image(tmp_path / "empty.png")
    cv2.imwrite(str(tmp_path / "deep.png"), np.zeros((2, 2), np.uint16))
    with pytest.raises(ValueError, match="8-bit"):
        read_image(tmp_path / "deep.png")


# --- read_disparity ---------------------------------------------------------------------------


def test_read_disparity_8bit_divisor_and_zero_is_inf(tmp_path):
    cv2.imwrite(str(tmp_path / "d.png"), np.array([[0, 3, 7]], np.uint8))
    out = read_disparity(tmp_path / "d.png", divisor=3)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, [[np.inf, 1.0, 7 / 3]], rtol=1e-7)
    with pytest.raises(ValueError, match="divisor: required"):
        read_disparity(tmp_path / "d.png")
    with pytest.raises(ValueError, match="divisor"):
        read_disparity(tmp_path / "d.png", divisor=0)


def test_read_disparity_16bit_kitti(tmp_path):
    cv2.imwrite(str(tmp_path / "k.png"), np.array([[0, 1, 256, 65535]], np.uint16))
    np.testing.assert_array_equal(
        read_disparity(tmp_path / "k.png"), np.array([[np.inf, 1 / 256, 1.0, 65535 / 256]], np.float32)
    )


def test_read_disparity_three_equal_channels_accepted_else_refused(tmp_path):
    cv2.imwrite(str(tmp_path / "e.png"), np.dstack([np.array([[0, 4]], np.uint8)] * 3))
    assert read_disparity(tmp_path / "e.png", divisor=2).tolist() == [[np.inf, 2.0]]
    cv2.imwrite(str(tmp_path / "u.png"), np.array([[[1, 2, 3]]], np.uint8))
    with pytest.raises(ValueError, match="single-channel"):
        read_disparity(tmp_path / "u.png", divisor=1)


def test_read_disparity_pfm(tmp_path):
    d = np.array([[1.25, np.inf]], np.float32)
    write_pfm(tmp_path / "d.pfm", d)
    np.testing.assert_array_equal(read_disparity(tmp_path / "d.pfm"), d)
    with pytest.raises(ValueError, match="divisor"):
        read_disparity(tmp_path / "d.pfm", divisor=2)
    write_pfm(tmp_path / "c.pfm", np.zeros((1, 1, 3)))
    with pytest.raises(ValueError, match="grey"):
        read_disparity(tmp_path / "c.pfm")


# --- calib.txt --------------------------------------------------------------------------------

MIDDLEBURY_2014_CALIB = """cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]
cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]
doffs=131.111
baseline=193.001
width=2964
height=1988
ndisp=280
isint=0
vmin=31
vmax=257
dyavg=0.918
dymax=1.516
"""


def test_parse_real_middlebury_calib_and_format_reproduces_it():
    calib = parse_calib(MIDDLEBURY_2014_CALIB)
    np.testing.assert_array_equal(
        calib["cam1"], [[3997.684, 0, 1307.839], [0, 3997.684, 1011.728], [0, 0, 1]]
    )
    assert calib["cam0"].shape == (3, 3) and calib["cam0"].dtype == np.float64
    assert (calib["doffs"], calib["baseline"], calib["dymax"]) == (131.111, 193.001, 1.516)
    assert (calib["width"], calib["height"], calib["ndisp"], calib["vmin"]) == (2964, 1988, 280, 31)
    assert all(type(calib[k]) is int for k in ("width", "height", "ndisp", "isint", "vmin", "vmax"))
    assert format_calib(calib) == MIDDLEBURY_2014_CALIB


def test_format_calib_orders_known_keys_first_and_keeps_extras(tmp_path):
    text = format_calib({"zeta": 0.5, "ndisp": 64.0, "cam0": [[1, 0, 0.25], [0, 1, 0], [0, 0, 1]]})
    assert text == "cam0=[1 0 0.25; 0 1 0; 0 0 1]\nndisp=64\nzeta=0.5\n"
    (tmp_path / "calib.txt").write_text(text)
    assert read_calib(tmp_path / "calib.txt")["zeta"] == 0.5


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("cam0", "key=value"),
        ("=3", "key=value"),
        ("cam0=[1 0 0; 0 1 0]", "3x3"),
        ("cam0=[1 0 0; 0 1 0; 0 0 1", "unterminated"),
        ("cam0=[1 0 a; 0 1 0; 0 0 1]", "non-numeric"),
        ("doffs=abc", "not a number"),
        ("width=2.5", "integer"),
    ],
)
def test_parse_calib_errors_name_the_line(text, message):
    with pytest.raises(ValueError, match=f"calib.txt, line 1: .*{message}"):
        parse_calib(text)


def test_format_calib_errors():
    with pytest.raises(ValueError, match="3x3"):
        format_calib({"cam0": np.eye(2)})
    with pytest.raises(ValueError, match="finite"):
        format_calib({"doffs": float("nan")})
    with pytest.raises(ValueError, match="key"):
        format_calib({"a=b": 1})


# --- Middlebury 2005/2006 ---------------------------------------------------------------------


def _toy_2005(root: Path, size: str = "third") -> Path:
    scene = root / size / "Toy"
    scene.mkdir(parents=True)
    img = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
    cv2.imwrite(str(scene / "view1.png"), img)
    cv2.imwrite(str(scene / "view5.png"), img[:, :, ::-1])
    cv2.imwrite(str(scene / "disp1.png"), np.array([[0, 3, 6], [9, 12, 0]], np.uint8))
    return scene


def test_load_middlebury_2005_toy(tmp_path):
    scene = _toy_2005(tmp_path)
    s = load_middlebury_2005(scene)
    assert s.name == "Toy" and s.disp_right is None and s.mask_left is None
    assert s.meta == {"dataset": "middlebury2005", "divisor": 3.0, "scene_dir": str(scene)}
    np.testing.assert_array_equal(s.disp_left, np.array([[np.inf, 1, 2], [3, 4, np.inf]], np.float32))
    np.testing.assert_array_equal(s.right, s.left[:, :, ::-1])
    assert load_middlebury_2005(scene, divisor=1).disp_left[1, 1] == 12.0


def test_divisor_inference_from_folder_names(tmp_path):
    assert infer_middlebury_2005_divisor("x/half/Baby1") == 2.0
    assert infer_middlebury_2005_divisor("x/ThirdSize/Baby1") == 3.0
    assert infer_middlebury_2005_divisor("FullSize/Baby1") == 1.0
    assert infer_middlebury_2005_divisor("half/third/Baby1") == 3.0  # nearest folder wins
    assert infer_middlebury_2005_divisor("x/HALFSIZE/Baby1") == 2.0  # any case
    assert infer_middlebury_2005_divisor("third/carefully/Baby1") == 3.0  # a word inside: none
    scene = _toy_2005(tmp_path, size="plain")
    with pytest.raises(ValueError, match="pass divisor=3"):
        load_middlebury_2005(scene)


@pytest.mark.parametrize("folder", ["carefully", "fullsets", "halfmoon", "thirdparty",
                                    "third_party", "Full-HD", "ThirdSizes"])
def test_a_word_inside_a_folder_name_says_no_size(tmp_path, folder):
    scene = _toy_2005(tmp_path / "real", size=folder)
    with pytest.raises(ValueError, match="no folder named third, half or full"):
        find_middlebury_2005_divisor(scene)
    with pytest.raises(ValueError, match="pass divisor=3"):
        load_middlebury_2005(scene)
    assert load_middlebury_2005(scene, divisor=3).meta["divisor"] == 3.0


def test_the_divisor_source_names_its_folder_and_how_far_up(tmp_path):
    src = find_middlebury_2005_divisor(tmp_path / "ThirdSize" / "mine" / "sets" / "Baby1")
    assert (src.divisor, src.folder.name, src.levels, src.far) == (3.0, "ThirdSize", 3, True)
    src = find_middlebury_2005_divisor(tmp_path / "third" / "Baby1")
    assert (src.folder, src.levels, src.far) == (tmp_path / "third", 1, False)


def test_an_inferred_divisor_the_image_size_contradicts_is_refused(tmp_path):
    scene = tmp_path / "full" / "Toy"
    scene.mkdir(parents=True)
    img = np.zeros((370, 463, 3), np.uint8)  # the third-size release's images
    cv2.imwrite(str(scene / "view1.png"), img)
    cv2.imwrite(str(scene / "view5.png"), img)
    cv2.imwrite(str(scene / "disp1.png"), np.full((370, 463), 30, np.uint8))
    with pytest.raises(ValueError, match=r"says full size \(divisor 1\).*463x370, the third size "
                                         r".*pass divisor=3"):
        load_middlebury_2005(scene)
    assert load_middlebury_2005(scene, divisor=1).disp_left[0, 0] == 30.0  # given: trusted
    assert divisor_of_shape((555, 620)) == 2.0 and divisor_of_shape((1110, 1390)) == 1.0
    assert divisor_of_shape((370, 600)) is None and divisor_of_shape((100, 463)) is None


def test_load_middlebury_2005_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="not a directory"):
        load_middlebury_2005(tmp_path / "nope", divisor=3)
    scene = _toy_2005(tmp_path)
    cv2.imwrite(str(scene / "disp5.png"), np.zeros((3, 3), np.uint8))
    with pytest.raises(ValueError, match="sizes differ"):
        load_middlebury_2005(scene)


@pytest.mark.realdata
@pytest.mark.parametrize("size", ["third", "half"])
@pytest.mark.parametrize("scene", SCENES)
def test_load_real_middlebury_2005(middlebury_dir, size, scene):
    s = load_middlebury_2005(middlebury_dir / size / scene)
    divisor = {"third": 3.0, "half": 2.0}[size]
    assert s.meta["divisor"] == divisor
    assert s.left.dtype == np.uint8 and s.left.ndim == 3 and s.left.shape == s.right.shape
    assert s.left.shape[0] == {"third": 370, "half": 555}[size]
    for disp in (s.disp_left, s.disp_right):
        assert disp.shape == s.left.shape[:2] and disp.dtype == np.float32
        finite = disp[np.isfinite(disp)]
        assert np.isposinf(disp[~np.isfinite(disp)]).all()
        assert 0 < finite.min() and finite.max() < {"third": 85, "half": 128}[size]  # README ranges
        np.testing.assert_array_equal(np.round(finite * divisor) / divisor, finite)  # integer codes
    # the ground truth agrees with the images: warping the right view lands on the left one
    rows, cols = np.nonzero(np.isfinite(s.disp_left))
    target = np.round(cols - s.disp_left[rows, cols]).astype(int)
    ok = target >= 0
    diff = np.abs(s.left[rows[ok], cols[ok]].astype(int) - s.right[rows[ok], target[ok]].astype(int))
    assert np.median(diff) <= 8


# --- Middlebury 2014 --------------------------------------------------------------------------


def _toy_2014(scene: Path, *, with_optional: bool) -> None:
    scene.mkdir(parents=True, exist_ok=True)
    img = np.full((2, 3, 3), 40, np.uint8)
    cv2.imwrite(str(scene / "im0.png"), img)
    cv2.imwrite(str(scene / "im1.png"), img)
    write_pfm(scene / "disp0.pfm", np.array([[1, 2, np.inf], [1.5, 2, 3]]))
    (scene / "calib.txt").write_text(MIDDLEBURY_2014_CALIB)
    if with_optional:
        write_pfm(scene / "disp1.pfm", np.array([[np.inf, 2, 1], [1, 1, 1]]))
        cv2.imwrite(str(scene / "mask0nocc.png"), np.array([[255, 128, 0], [255, 255, 255]], np.uint8))


def test_load_middlebury_2014(tmp_path):
    _toy_2014(tmp_path / "Toy", with_optional=False)
    s = load_middlebury_2014(tmp_path / "Toy")
    assert s.disp_right is None and s.mask_left is None and s.name == "Toy"
    assert s.disp_left.tolist() == [[1, 2, np.inf], [1.5, 2, 3]]
    assert s.meta["calib"]["ndisp"] == 280 and s.meta["dataset"] == "middlebury2014"
    _toy_2014(tmp_path / "Toy", with_optional=True)
    s = load_middlebury_2014(tmp_path / "Toy")
    assert s.disp_right[0, 2] == 1.0
    assert s.mask_left.tolist() == [[255, 128, 0], [255, 255, 255]]


def test_load_middlebury_2014_missing_files(tmp_path):
    _toy_2014(tmp_path / "Toy", with_optional=False)
    (tmp_path / "Toy" / "calib.txt").unlink()  # optional: a validate pair of a real scene
    assert load_middlebury_2014(tmp_path / "Toy").meta["calib"] is None
    (tmp_path / "Toy" / "im1.png").unlink()
    with pytest.raises(FileNotFoundError):
        load_middlebury_2014(tmp_path / "Toy")


# --- KITTI 2015 -------------------------------------------------------------------------------


def _toy_kitti(root: Path, index: int, *, noc: bool) -> None:
    name = f"{index:06d}_10.png"
    for sub in ("image_2", "image_3", "disp_occ_0", "disp_noc_0"):
        (root / sub).mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(root / "image_2" / name), np.zeros((1, 3, 3), np.uint8))
    cv2.imwrite(str(root / "image_3" / name), np.ones((1, 3, 3), np.uint8))
    cv2.imwrite(str(root / "disp_occ_0" / name), np.array([[0, 512, 1000]], np.uint16))
    if noc:
        cv2.imwrite(str(root / "disp_noc_0" / name), np.array([[0, 512, 0]], np.uint16))


def test_load_kitti_2015_occ_noc_and_mask(tmp_path):
    _toy_kitti(tmp_path, 42, noc=True)
    s = load_kitti_2015(tmp_path, 42)
    assert s.name == "000042" and s.disp_right is None
    assert s.disp_left.tolist() == [[np.inf, 2.0, 1000 / 256]]
    assert s.mask_left.tolist() == [[0, 255, 128]]
    assert load_kitti_2015(tmp_path, 42, occ=False).disp_left.tolist() == [[np.inf, 2.0, np.inf]]
    assert s.right.tolist() == [[[1, 1, 1]] * 3]


def test_load_kitti_2015_without_noc_has_no_mask(tmp_path):
    _toy_kitti(tmp_path, 0, noc=False)
    assert load_kitti_2015(tmp_path, 0).mask_left is None
    with pytest.raises(FileNotFoundError):
        load_kitti_2015(tmp_path, 0, occ=False)
    with pytest.raises(FileNotFoundError):
        load_kitti_2015(tmp_path, 1)
    with pytest.raises(ValueError, match="index"):
        load_kitti_2015(tmp_path, -1)
