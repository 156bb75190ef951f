"""One pair on disk (synth.write.export): the KITTI object map, the staged output folder."""

from __future__ import annotations

import os

import numpy as np
import pytest

from scenes import get_preset, plane_equation
from synth.write.export import foreground_map, staged_output_dir
from synth.pair import StereoPair
from synth.camera.rig import StereoRig


def _pair(disp_left: np.ndarray, rig: StereoRig) -> StereoPair:
    h, w = disp_left.shape
    image = np.zeros((h, w, 3), np.uint8)
    mask = np.where(np.isfinite(disp_left), 255, 0).astype(np.uint8)
    return StereoPair(left=image, right=image, disp_left=disp_left.astype(np.float32),
                      disp_right=disp_left.astype(np.float32), depth_left=disp_left,
                      mask_left=mask, rig=rig, meta={})


def test_obj_map_is_background_on_the_planes_foreground_elsewhere_and_0_without_gt():
    rig = StereoRig.default(16, 12)
    scene = get_preset("boxes")  # four boxes before a wall (the one plane object)
    (wall,) = [o for o in scene.objects if o.kind == "plane"]
    disp = rig.plane_disparity(*plane_equation(wall))
    disp[2:5, 4:9] += 3.0  # a box: nearer than the wall
    disp[:, :3] = np.inf  # no ground truth (nothing rendered there)
    disp[8, 10] = np.nan
    expected = np.zeros(disp.shape, np.uint8)
    expected[2:5, 4:9] = 1
    obj = foreground_map(_pair(disp, rig), scene)
    assert obj.dtype == np.uint8
    np.testing.assert_array_equal(obj, expected)


@pytest.fixture
def umask_022():
    old = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(old)


def test_a_staged_output_folder_gets_the_umask_mode_not_mkdtemps_0700(tmp_path, umask_022):
    with staged_output_dir(tmp_path / "pair") as stage:
        (stage / "a.txt").write_text("hi")
    assert (tmp_path / "pair").stat().st_mode & 0o777 == 0o755  # others may read the pair
