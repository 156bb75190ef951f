"""Hand-picked examples for the Middlebury and KITTI writers (``matcher.io.middlebury``,
``matcher.io.kitti``); atomic writes are in ``test_io_atomic.py``."""

from __future__ import annotations

import struct

import cv2
import numpy as np
import pytest

from matcher.io import (
    KITTI_MAX_DISPARITY,
    encode_kitti_disparity,
    load_kitti_2015,
    load_middlebury_2014,
    read_calib,
    write_kitti,
    write_middlebury,
)

K = np.array([[500.0, 0, 1.5], [0, 500.0, 0.5], [0, 0, 1]])
CALIB = {"cam0": K, "cam1": K, "doffs": 0.0, "baseline": 120.0, "ndisp": 16}


def _frame():
    left = np.arange(2 * 4 * 3, dtype=np.uint8).reshape(2, 4, 3)
    right = left[:, ::-1].copy()
    disp = np.array([[1.0, 2.5, np.inf, 3.25], [0.0, 7.0, 8.0, np.inf]], np.float32)
    mask = np.array([[255, 128, 0, 255], [255, 255, 128, 0]], np.uint8)
    disp_right = np.array([[np.inf, 1, 1, 1], [2, 2, np.nan, 2]], np.float32)
    return left, right, disp, mask, disp_right


def _files(root):
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())


# --- Middlebury -------------------------------------------------------------------------------


def test_write_middlebury_round_trip(tmp_path):
    left, right, disp, mask, disp_right = _frame()
    out = tmp_path / "scene"
    files = write_middlebury(out, left=left, right=right, disp_left=disp, disp_right=disp_right,
                             mask_left=mask, calib=CALIB)
    assert [f.name for f in files] == ["im0.png", "im1.png", "im1E.png", "im1L.png", "disp0GT.pfm",
                                       "disp1GT.pfm", "mask0nocc.png", "calib.txt"]
    assert _files(out) == sorted(f.name for f in files)  # no temporary files left behind
    s = load_middlebury_2014(out)
    np.testing.assert_array_equal(s.left, left)
    np.testing.assert_array_equal(s.right, right)
    np.testing.assert_array_equal(s.disp_left, disp)
    np.testing.assert_array_equal(s.disp_right, np.where(np.isnan(disp_right), np.inf, disp_right))
    np.testing.assert_array_equal(s.mask_left, mask)
    assert (out / "disp0GT.pfm").read_bytes()[:14] == b"Pf\n4 2\n-1\n" + struct.pack("<f", 0.0)  # bottom row first


def test_calib_txt_exact_text(tmp_path):
    left, right, disp, mask, _ = _frame()
    write_middlebury(tmp_path, left=left, right=right, disp_left=disp, disp_right=None,
                     mask_left=mask, calib=CALIB | {"isint": 0})
    assert (tmp_path / "calib.txt").read_text() == (
        "cam0=[500 0 1.5; 0 500 0.5; 0 0 1]\n"
        "cam1=[500 0 1.5; 0 500 0.5; 0 0 1]\n"
        "doffs=0\n"
        "baseline=120\n"
        "width=4\n"
        "height=2\n"
        "ndisp=16\n"
        "isint=0\n"
        "vmin=0\n"
        "vmax=8\n"
    )
    assert not (tmp_path / "disp1GT.pfm").exists()
    assert read_calib(tmp_path / "calib.txt")["cam0"].tolist() == K.tolist()


def test_grey_images_and_explicit_vmin_vmax(tmp_path):
    _, _, disp, mask, _ = _frame()
    grey = np.full((2, 4), 9, np.uint8)
    write_middlebury(tmp_path, left=grey, right=grey, disp_left=disp, disp_right=None,
                     mask_left=mask, calib=CALIB | {"vmin": 0.5, "vmax": 8.25, "width": 4})
    s = load_middlebury_2014(tmp_path)
    assert s.left.tolist() == grey.tolist()
    assert (s.meta["calib"]["vmin"], s.meta["calib"]["vmax"]) == (0.5, 8.25)


@pytest.mark.parametrize(
    ("change", "error", "message"),
    [
        ({"left": np.zeros((2, 4, 3), np.float32)}, TypeError, "left: expected a uint8"),
        ({"right": np.zeros((2, 5, 3), np.uint8)}, ValueError, "same shape"),
        ({"mask_left": np.full((2, 4), 200, np.uint8)}, ValueError, "codes"),
        ({"disp_left": np.ones((2, 4), np.float32)}, ValueError, "finite exactly where"),
        ({"disp_right": -np.ones((2, 4))}, ValueError, "disp_right: expected disparities >= 0"),
        ({"disp_left": np.ones((2, 4), np.uint8)}, TypeError, "disp_left"),
        ({"calib": {"cam0": K}}, ValueError, "missing keys"),
        ({"calib": CALIB | {"width": 5}}, ValueError, r"calib\['width'\]: expected 4"),
        ({"calib": CALIB | {"cam1": np.eye(2)}}, ValueError, "3x3"),
    ],
)
def test_write_middlebury_refuses_bad_input_before_writing(tmp_path, change, error, message):
    left, right, disp, mask, disp_right = _frame()
    args = dict(left=left, right=right, disp_left=disp, disp_right=disp_right, mask_left=mask, calib=CALIB)
    out = tmp_path / "scene"
    with pytest.raises(error, match=message):
        write_middlebury(out, **(args | change))
    assert not out.exists()


# --- KITTI ------------------------------------------------------------------------------------


def test_write_kitti_round_trip(tmp_path):
    left, right, disp, mask, _ = _frame()
    files = write_kitti(tmp_path, 12, left=left, right=right, disp_left=disp, mask_left=mask)
    assert [str(f.relative_to(tmp_path)) for f in files] == [
        "image_2/000012_10.png", "image_3/000012_10.png", "disp_occ_0/000012_10.png", "disp_noc_0/000012_10.png"]
    assert _files(tmp_path) == sorted(str(f.relative_to(tmp_path)) for f in files)
    occ = cv2.imread(str(files[2]), cv2.IMREAD_UNCHANGED)
    noc = cv2.imread(str(files[3]), cv2.IMREAD_UNCHANGED)
    assert occ.dtype == np.uint16
    assert occ.tolist() == [[256, 640, 0, 832], [1, 1792, 2048, 0]]  # d = 0 stored as 1 (valid)
    assert noc.tolist() == [[256, 0, 0, 832], [1, 1792, 0, 0]]
    s = load_kitti_2015(tmp_path, 12)
    np.testing.assert_array_equal(s.left, left)
    np.testing.assert_array_equal(s.right, right)
    np.testing.assert_array_equal(s.mask_left, mask)
    np.testing.assert_allclose(s.disp_left, np.where(disp == 0, 1 / 256, disp))


def test_kitti_encoding_limits():
    assert encode_kitti_disparity(np.array([[KITTI_MAX_DISPARITY, 1 / 600, np.nan]])).tolist() == [[65535, 1, 0]]
    assert encode_kitti_disparity(np.array([[0.5 / 256 + 1e-9, 1.5 / 256]])).tolist() == [[1, 2]]


@pytest.mark.parametrize("bad", [256.0, 255.999, 1e9, -0.25])
def test_write_kitti_refuses_unstorable_disparity_before_writing(tmp_path, bad):
    left, right, disp, mask, _ = _frame()
    disp = disp.copy()
    disp[1, 1] = bad
    with pytest.raises(ValueError, match="at row 1, column 1"):
        write_kitti(tmp_path / "k", 0, left=left, right=right, disp_left=disp, mask_left=mask)
    assert not (tmp_path / "k").exists()


def test_write_kitti_bad_index(tmp_path):
    left, right, disp, mask, _ = _frame()
    for index in (-1, 10**6, 1.0, True):
        with pytest.raises(ValueError, match="index"):
            write_kitti(tmp_path, index, left=left, right=right, disp_left=disp, mask_left=mask)


def test_calib_isint_defaults_to_0_and_gt_uses_the_middeval3_names(tmp_path):
    """Without ``isint`` the MiddEval3 SDK's runeval shifts evaldisp's arguments and scores
    occluded pixels too; the writer always writes it (0: float disparities)."""
    left, right, disp, mask, disp_right = _frame()
    write_middlebury(tmp_path, left=left, right=right, disp_left=disp, disp_right=disp_right,
                     mask_left=mask, calib=CALIB)
    assert "isint=0\n" in (tmp_path / "calib.txt").read_text()
    assert read_calib(tmp_path / "calib.txt")["isint"] == 0
    assert not (tmp_path / "disp0.pfm").exists() and (tmp_path / "disp0GT.pfm").is_file()
    for name in ("im1E.png", "im1L.png"):
        assert (tmp_path / name).read_bytes() == (tmp_path / "im1.png").read_bytes()


def test_the_2014_layout_renames_the_ground_truth_and_changes_no_byte(tmp_path):
    """``layout="2014"``: the 2014 scene archives' ``disp0.pfm``/``disp1.pfm`` (RAFT-Stereo's
    ``split="2014"``) instead of MiddEval3's names; every file has the MiddEval3 layout's bytes."""
    left, right, disp, mask, disp_right = _frame()
    kw = dict(left=left, right=right, disp_left=disp, disp_right=disp_right, mask_left=mask,
              calib=CALIB, right_exposure=right // 2, highlight_left=mask, highlight_right=mask)
    middeval3 = write_middlebury(tmp_path / "mv3", **kw)
    files = write_middlebury(tmp_path / "2014", layout="2014", **kw)
    renamed = {"disp0GT.pfm": "disp0.pfm", "disp1GT.pfm": "disp1.pfm"}
    assert [f.name for f in files] == [renamed.get(f.name, f.name) for f in middeval3]
    assert _files(tmp_path / "2014") == sorted(f.name for f in files)
    for a, b in zip(middeval3, files):
        assert a.read_bytes() == b.read_bytes(), b.name
    s = load_middlebury_2014(tmp_path / "2014")
    np.testing.assert_array_equal(s.disp_left, disp)
    np.testing.assert_array_equal(s.disp_right, np.where(np.isnan(disp_right), np.inf, disp_right))
    np.testing.assert_array_equal(s.mask_left, mask)
    with pytest.raises(ValueError, match=r"layout: expected one of \['middeval3', '2014'\]"):
        write_middlebury(tmp_path / "bad", layout="MiddEval3", **kw)
    assert not (tmp_path / "bad").exists()


def test_middlebury_variants_and_highlight_masks_replace_the_copies(tmp_path):
    left, right, disp, mask, disp_right = _frame()
    exposed, relit = right // 2, 255 - right
    spec = np.array([[0, 255, 0, 0], [0, 0, 0, 0]], np.uint8)
    files = write_middlebury(tmp_path, left=left, right=right, disp_left=disp, disp_right=None,
                             mask_left=mask, calib=CALIB, right_exposure=exposed,
                             right_lighting=relit, highlight_left=spec, highlight_right=spec[:, ::-1])
    assert [f.name for f in files] == ["im0.png", "im1.png", "im1E.png", "im1L.png", "disp0GT.pfm",
                                       "mask0nocc.png", "mask0spec.png", "mask1spec.png",
                                       "calib.txt"]
    read = lambda name: cv2.imread(str(tmp_path / name), cv2.IMREAD_UNCHANGED)  # noqa: E731
    assert np.array_equal(read("im1E.png")[..., ::-1], exposed)
    assert np.array_equal(read("im1L.png")[..., ::-1], relit)
    assert np.array_equal(read("mask1spec.png"), spec[:, ::-1])


@pytest.mark.parametrize(("kw", "match"), [
    ({"right_exposure": np.zeros((2, 3, 3), np.uint8)}, r"right_exposure: expected the shape"),
    ({"right_lighting": np.zeros((2, 4, 3), np.float32)}, r"uint8"),
    ({"highlight_left": np.zeros((2, 4), np.uint8)}, r"both or neither"),
])
def test_middlebury_bad_variants_are_refused_before_writing(tmp_path, kw, match):
    left, right, disp, mask, _ = _frame()
    with pytest.raises((ValueError, TypeError), match=match):
        write_middlebury(tmp_path / "s", left=left, right=right, disp_left=disp, disp_right=None,
                         mask_left=mask, calib=CALIB, **kw)
    assert not (tmp_path / "s").exists()
