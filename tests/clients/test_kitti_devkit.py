"""The KITTI 2015 devkit's ``evaluate_scene_flow`` (built from ../shared/clients with the edits
of its SOURCES.txt) evaluates a folder written by ``write_kitti`` as it is, and its D1 figures
equal ``matcher.benchmarks.kitti_2015`` on it."""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest

from matcher.io import (
    encode_kitti_disparity,
    encode_png,
    format_kitti_calib,
    load_kitti_2015,
    read_disparity,
    read_image,
    read_kitti_calib,
    write_kitti,
)
from matcher.benchmarks import kitti_2015

H, W = 40, 96


def _frame(seed: int):
    rng = np.random.default_rng(seed)
    x = np.arange(W)[None, :].repeat(H, 0)
    gt = (20.0 + 0.1 * x + 0.05 * np.arange(H)[:, None]).astype(np.float32)
    obj = np.zeros((H, W), np.uint8)
    obj[8:30, 30:60] = 3  # a car, 3 = its instance id
    gt[obj > 0] = 55.5
    mask = np.full((H, W), 255, np.uint8)
    mask[8:30, 60:66] = 128  # occluded beside the car
    mask[:2] = 0  # sky: no ground truth (invalid rows at the top, as in KITTI)
    gt[mask == 0] = np.inf
    est = gt + rng.normal(0, 1.0, (H, W))
    bad = rng.random((H, W)) < 0.08
    est[bad] += rng.uniform(-20, 20, int(bad.sum()))
    est[rng.random((H, W)) < 0.07] = np.inf  # holes the devkit interpolates
    est[20, :4] = np.inf  # a hole at the border: extrapolated
    est[5] = np.inf  # a whole row: filled by nothing
    est = np.where(np.isfinite(est), np.clip(est, 0, 255), np.inf)
    img = rng.integers(0, 256, (H, W, 3), dtype=np.uint8)
    return img, np.where(np.isfinite(gt), gt, np.inf), mask, obj, est


def _devkit_layout(tmp: Path, frames: int) -> dict[int, np.ndarray]:
    root = tmp / "training"
    ests = {}
    calib = format_kitti_calib(fx=721.5, fy=721.5, cx=47.5, cy=19.5, baseline=0.54, width=W, height=H)
    for i in range(frames):
        img, gt, mask, obj, est = _frame(i)
        write_kitti(root, i, left=img, right=img, disp_left=gt, mask_left=mask, obj_map=obj,
                    calib=calib, fsync=False)
        result = tmp / "results" / "sha" / "data" / "disp_0" / f"{i:06d}_10.png"
        result.parent.mkdir(parents=True, exist_ok=True)
        result.write_bytes(encode_png(encode_kitti_disparity(est)))
        ests[i] = read_disparity(result)  # what the devkit sees: 1/256 px steps, 0 = hole
    (tmp / "data").mkdir()
    (tmp / "data" / "scene_flow").symlink_to(root)  # the devkit's hard-coded GT folder
    return ests


def _ratio(x: float) -> float:
    return 0.0 if math.isnan(x) else x / 100.0  # the devkit prints n / max(N, 1)


def test_devkit_equals_kitti_2015(kitti_devkit, tmp_path):
    frames = 2
    ests = _devkit_layout(tmp_path, frames)
    done = subprocess.run([str(kitti_devkit(frames)), "sha"], cwd=tmp_path, capture_output=True,
                          text=True)
    assert "Couldn't read" not in done.stdout and done.returncode == 0, done.stdout
    result = tmp_path / "results" / "sha"
    assert (result / "stats_disp_occ_0.txt").is_file(), done.stdout
    for i, est in ests.items():
        s_occ = load_kitti_2015(tmp_path / "training", i)
        obj = read_image(tmp_path / "training" / "obj_map" / f"{i:06d}_10.png")
        ours = kitti_2015(est, s_occ.disp_left, occlusion_mask=s_occ.mask_left, obj_map=obj)
        for region, d1 in (("occ", ours.occ), ("noc", ours.noc)):
            theirs = [float(v) for v in (result / f"errors_disp_{region}_0" / f"{i:06d}_10.txt").read_text().split()]
            mine = [_ratio(d1.bg), _ratio(d1.bg_est), _ratio(d1.fg), _ratio(d1.fg_est), _ratio(d1.all),
                    _ratio(d1.all_est), d1.density / 100.0]
            np.testing.assert_allclose(theirs, mine, atol=1e-6, err_msg=f"frame {i} {region}")
        assert 0 < ours.occ.fg < 100 and ours.occ.all != ours.noc.all


def test_calib_cam_to_cam_round_trip(tmp_path):
    img, gt, mask, obj, _ = _frame(0)
    text = format_kitti_calib(fx=721.5377, fy=721.5377, cx=609.5593, cy=172.854, baseline=0.5327119,
                              width=W, height=H)
    files = write_kitti(tmp_path, 7, left=img, right=img, disp_left=gt, mask_left=mask, obj_map=obj,
                        calib=text, fsync=False)
    assert [f.relative_to(tmp_path).as_posix() for f in files][-2:] == ["obj_map/000007_10.png",
                                                                        "calib_cam_to_cam/000007.txt"]
    c = read_kitti_calib(tmp_path / "calib_cam_to_cam" / "000007.txt")
    p2, p3 = c["P_rect_02"], c["P_rect_03"]
    assert p2.shape == p3.shape == (3, 4) and p2[0, 0] == 721.5377
    assert (p2[0, 3] - p3[0, 3]) / p2[0, 0] == np.float64(721.5377 * 0.5327119) / 721.5377
    np.testing.assert_array_equal(c["S_rect_02"], [W, H])
    np.testing.assert_array_equal(read_image(tmp_path / "obj_map" / "000007_10.png"), obj)


@pytest.mark.gl
def test_devkit_evaluates_a_dataset_directory_as_it_is(kitti_devkit, renderer, tmp_path):
    """A KITTI dataset written by run_dataset: DIR/training is the devkit's ground-truth folder
    as it is (the sample folders, header, manifests and records do not disturb it)."""
    from synth.dataset.config.parse import loads_config
    from synth.dataset.run import run_dataset

    out = tmp_path / "ds"
    run_dataset(loads_config("seed = 5\ncount = 2\n[rig]\nwidth = 64\nheight = 48\n[scene]\n"
                             'base = "boxes"\n'), out=out, fmt="kitti", progress=False)
    rng = np.random.default_rng(1)
    ests = {}
    for i in range(2):
        gt = load_kitti_2015(out / "training", i).disp_left
        est = np.where(np.isfinite(gt), np.clip(gt + rng.normal(0, 2.0, gt.shape), 0, 255), np.inf)
        result = tmp_path / "results" / "sha" / "data" / "disp_0" / f"{i:06d}_10.png"
        result.parent.mkdir(parents=True, exist_ok=True)
        result.write_bytes(encode_png(encode_kitti_disparity(est)))
        ests[i] = read_disparity(result)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "scene_flow").symlink_to(out / "training")
    done = subprocess.run([str(kitti_devkit(2)), "sha"], cwd=tmp_path, capture_output=True,
                          text=True)
    assert "Couldn't read" not in done.stdout and done.returncode == 0, done.stdout
    for i, est in ests.items():
        s = load_kitti_2015(out / "training", i)
        obj = read_image(out / "training" / "obj_map" / f"{i:06d}_10.png")
        ours = kitti_2015(est, s.disp_left, occlusion_mask=s.mask_left, obj_map=obj)
        theirs = [float(v) for v in (tmp_path / "results" / "sha" / "errors_disp_occ_0"
                                     / f"{i:06d}_10.txt").read_text().split()]
        np.testing.assert_allclose(theirs[4:6], [_ratio(ours.occ.all), _ratio(ours.occ.all_est)],
                                   atol=1e-6, err_msg=f"frame {i}")
