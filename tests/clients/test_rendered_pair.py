"""A rendered pair (``boxes``) written by ``write_pair`` in both layouts and an LR-checked census
estimate: the MiddEval3 SDK's evaldisp and the KITTI devkit give the figures our benchmark
metrics give."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from matcher import match
from matcher.io import encode_kitti_disparity, encode_png, load_kitti_2015, load_middlebury_2014, read_disparity, read_image, write_pfm
from matcher.benchmarks import kitti_2015, middlebury_v3
from scenes import get_preset
from synth.write.export import write_pair
from synth.pair import render_pair
from synth.camera.rig import StereoRig


@pytest.mark.gl
@pytest.mark.slow
def test_boxes_sdk_and_devkit_equal_ours(renderer, middeval_sdk, kitti_devkit, tmp_path):
    rig = StereoRig.default(160, 120)
    spec = get_preset("boxes", seed=0)
    pair = render_pair(spec, rig, renderer=renderer)
    mb, kt = tmp_path / "trainingF" / "boxes", tmp_path / "k"
    mb.mkdir(parents=True)
    write_pair(pair, mb, scene=spec, seed=0, fsync=False, preview=False)
    write_pair(pair, kt, scene=spec, seed=0, fmt="kitti", fsync=False, preview=False)
    est = match(pair.left, pair.right, method="ct", window=9, max_disparity=64, lr_check=True).disparity
    write_pfm(mb / "disp0CT.pfm", est)
    s = load_middlebury_2014(mb)
    ndisp = s.meta["calib"]["ndisp"]
    for region, extra in (("nonocc", [mb / "mask0nocc.png"]), ("all", [])):
        out = subprocess.run([str(middeval_sdk / "code" / "evaldisp"), str(mb / "disp0CT.pfm"),
                              str(mb / "disp0GT.pfm"), "2.0", str(ndisp), "0", *map(str, extra)],
                             capture_output=True, text=True, check=True).stdout
        theirs = [float(v) for v in out.split()]
        m = middlebury_v3(est, s.disp_left, occlusion_mask=s.mask_left, region=region, maxdisp=ndisp)
        ours = [m.mask, m.bad_2, m.invalid, m.total_bad_2, m.avgerr]
        # evaldisp prints the mask with 1 decimal, the rest with 2
        assert np.all(np.abs(np.subtract(theirs, ours)) <= [0.051, 0.0051, 0.0051, 0.0051, 0.0051]), (theirs, ours)
        print(f"boxes middlebury {region}: evaldisp {theirs}, ours {ours}")

    png = tmp_path / "results" / "sha" / "data" / "disp_0" / "000000_10.png"
    png.parent.mkdir(parents=True)
    png.write_bytes(encode_png(encode_kitti_disparity(np.where(np.isfinite(est), np.clip(est, 0, 255), np.inf))))
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "scene_flow").symlink_to(kt / "training")
    done = subprocess.run([str(kitti_devkit(1)), "sha"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0 and "Couldn't read" not in done.stdout, done.stdout
    k = load_kitti_2015(kt / "training", 0)
    ours = kitti_2015(read_disparity(png), k.disp_left, occlusion_mask=k.mask_left,
                      obj_map=read_image(kt / "training" / "obj_map" / "000000_10.png"))
    for region, d1 in (("occ", ours.occ), ("noc", ours.noc)):
        theirs = [float(v) for v in (tmp_path / "results" / "sha" / f"stats_disp_{region}_0.txt").read_text().split()]
        mine = [d1.bg / 100, d1.bg_est / 100, d1.fg / 100, d1.fg_est / 100, d1.all / 100,
                d1.all_est / 100, d1.density / 100]
        np.testing.assert_allclose(theirs, mine, atol=1e-6)
        print(f"boxes kitti {region}: devkit {theirs}, ours {mine}")
