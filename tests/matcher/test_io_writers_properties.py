"""Property: writer -> reader round trips for both layouts.

Hand-picked companions: ``test_write_middlebury_round_trip``, ``test_write_kitti_round_trip``.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from matcher.io import load_kitti_2015, load_middlebury_2014, write_kitti, write_middlebury

K = np.array([[100.0, 0, 7.5], [0, 100.0, 7.5], [0, 0, 1]])


@st.composite
def frames(draw, *, max_disparity):
    h, w = draw(st.integers(1, 16)), draw(st.integers(1, 16))
    channels = draw(st.sampled_from([(), (3,)]))
    left = draw(hnp.arrays(np.uint8, (h, w, *channels)))
    right = draw(hnp.arrays(np.uint8, (h, w, *channels)))
    mask = draw(hnp.arrays(np.uint8, (h, w), elements=st.sampled_from([0, 128, 255])))
    values = draw(hnp.arrays(np.float32, (h, w), elements=st.floats(0, max_disparity, width=32)))
    disp = np.where(mask == 0, np.float32(np.inf), values).astype(np.float32)
    return left, right, disp, mask


@given(frame=frames(max_disparity=1e6), with_right=st.booleans())
def test_middlebury_round_trip(tmp_path_factory, frame, with_right):
    left, right, disp, mask = frame
    out = tmp_path_factory.mktemp("mb")
    disp_right = disp[:, ::-1].copy() if with_right else None
    calib = {"cam0": K, "cam1": K, "doffs": 0.0, "baseline": 50.0, "ndisp": 64}
    write_middlebury(out, left=left, right=right, disp_left=disp, disp_right=disp_right,
                     mask_left=mask, calib=calib, fsync=False)
    s = load_middlebury_2014(out)
    np.testing.assert_array_equal(s.left, left)
    np.testing.assert_array_equal(s.right, right)
    np.testing.assert_array_equal(s.disp_left, disp)  # float32 PFM: exact
    np.testing.assert_array_equal(s.mask_left, mask)
    if with_right:
        np.testing.assert_array_equal(s.disp_right, disp_right)
    else:
        assert s.disp_right is None
    assert (s.meta["calib"]["width"], s.meta["calib"]["height"]) == (left.shape[1], left.shape[0])
    finite = disp[np.isfinite(disp)]
    if finite.size:
        assert s.meta["calib"]["vmin"] <= finite.min() and finite.max() <= s.meta["calib"]["vmax"]


@given(frame=frames(max_disparity=65535 / 256), index=st.integers(0, 999999))
def test_kitti_round_trip(tmp_path_factory, frame, index):
    left, right, disp, mask = frame
    root = tmp_path_factory.mktemp("kitti")
    write_kitti(root, index, left=left, right=right, disp_left=disp, mask_left=mask, fsync=False)
    occ = load_kitti_2015(root, index)
    noc = load_kitti_2015(root, index, occ=False)
    np.testing.assert_array_equal(occ.left, left)
    np.testing.assert_array_equal(occ.right, right)
    np.testing.assert_array_equal(occ.mask_left, mask)
    assert np.array_equal(np.isfinite(occ.disp_left), mask != 0)
    assert np.array_equal(np.isfinite(noc.disp_left), mask == 255)
    valid = mask != 0
    # quantised to 1/256 px, and valid disparities below 1/512 px stored as 1/256 (code 0 is invalid)
    np.testing.assert_allclose(occ.disp_left[valid], disp[valid], rtol=0, atol=1 / 256)
    expected = np.maximum(np.rint(disp[valid].astype(np.float64) * 256), 1) / 256
    np.testing.assert_array_equal(occ.disp_left[valid], expected.astype(np.float32))
    np.testing.assert_array_equal(noc.disp_left[mask == 255], occ.disp_left[mask == 255])


@given(image=st.one_of(
    hnp.arrays(np.uint8, st.tuples(st.integers(1, 24), st.integers(1, 24))),
    hnp.arrays(np.uint8, st.tuples(st.integers(1, 24), st.integers(1, 24), st.just(3))),
    hnp.arrays(np.uint16, st.tuples(st.integers(1, 16), st.integers(1, 16)))),
    deflate=st.sampled_from(["zlib", "isal", "libdeflate"]))
def test_png_round_trips_through_opencv(image, deflate):
    import cv2

    from matcher.io import encode_png

    back = cv2.imdecode(np.frombuffer(encode_png(image, deflate=deflate), np.uint8),
                        cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(back[..., ::-1] if back.ndim == 3 else back, image)
