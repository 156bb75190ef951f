"""The MiddEval3 SDK 1.6 (``runeval``, ``evaldisp``, ``computemask``, built from
../shared/clients) reads scene folders written by ``write_middlebury`` as they are, and its figures
equal ``matcher.benchmarks.middlebury_v3`` on them."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from matcher.io import read_calib, read_image, write_middlebury, write_pfm
from matcher.benchmarks import middlebury_v3
from synth.pair import occlusion_mask

H, W = 48, 64


def synthetic_scene(seed: int):
    """Left/right ground truth of a slanted wall with a nearer box, the mask, and an estimate
    with noise, gross errors, values above ndisp, holes."""
    rng = np.random.default_rng(seed)
    x = np.arange(W, dtype=np.float64)[None, :].repeat(H, 0)
    wall = 6.0 + 0.05 * x + 0.02 * np.arange(H)[:, None]
    box = np.zeros((H, W), bool)
    box[10:30, 20:40] = True
    disp_left = np.where(box, 14.25, wall).astype(np.float32)
    disp_left[:3, :5] = np.inf  # no ground truth
    # the right view: x_right = x_left - d, so the wall's right disparity solves d = wall(x + d)
    wall_right = (6.0 + 0.05 * x + 0.02 * np.arange(H)[:, None]) / 0.95
    box_right = np.zeros((H, W), bool)
    box_right[10:30, 6:26] = True  # columns 20..39 shifted by 14.25, at pixel centres 5.75..25.75
    disp_right = np.where(box_right, 14.25, wall_right).astype(np.float32)
    mask = occlusion_mask(disp_left, disp_right)
    mask[:3, :5] = 0
    est = disp_left.astype(np.float64) + rng.normal(0, 0.6, (H, W))
    gross = rng.random((H, W)) < 0.05
    est[gross] += rng.uniform(-12, 12, int(gross.sum()))
    est[rng.random((H, W)) < 0.06] = np.inf
    est[0, 10] = 1e9  # above 1000 * ndisp: evaldisp counts it invalid
    est[1, 10] = 40.0  # above ndisp: clipped
    est[2, 10] = -3.0  # negative: clipped to 0
    img = rng.integers(0, 256, (H, W, 3), dtype=np.uint8)
    return img, disp_left, disp_right, mask, est.astype(np.float32)


def _write_scene(scene_dir: Path, seed: int) -> np.ndarray:
    img, disp_left, disp_right, mask, est = synthetic_scene(seed)
    K = np.array([[500.0, 0, 31.5], [0, 500, 23.5], [0, 0, 1]])
    write_middlebury(scene_dir, left=img, right=img, disp_left=disp_left, disp_right=disp_right,
                     mask_left=mask, calib={"cam0": K, "cam1": K, "doffs": 0, "baseline": 100,
                                            "ndisp": 32}, fsync=False)
    write_pfm(scene_dir / "disp0Noisy.pfm", est)
    return est


def _evaldisp(sdk: Path, *args: object) -> list[float]:
    out = subprocess.run([str(sdk / "code" / "evaldisp"), *map(str, args)], capture_output=True,
                         text=True, check=True).stdout
    return [float(v) for v in out.split()]


def _ours(est, scene_dir: Path, region: str, thresh: float) -> list[float]:
    gt = read_image  # noqa: F841  (the GT is read the same way as the SDK: from the files)
    from matcher.io import load_middlebury_2014

    s = load_middlebury_2014(scene_dir)
    calib = s.meta["calib"]
    m = middlebury_v3(est, s.disp_left, occlusion_mask=s.mask_left, region=region,
                      maxdisp=calib["ndisp"], rounddisp=bool(calib["isint"]))
    key = {0.5: "0_5", 1.0: "1", 2.0: "2", 4.0: "4"}[thresh]
    return [m.mask, getattr(m, f"bad_{key}"), m.invalid, getattr(m, f"total_bad_{key}"), m.avgerr]


def _assert_same(sdk_row: list[float], ours: list[float]) -> None:
    # evaldisp prints 1 (mask) or 2 decimals and sums its errors in float32
    for column, (theirs, mine) in enumerate(zip(sdk_row, ours)):
        tol = 0.051 if column == 0 else 0.0051
        assert abs(theirs - mine) <= tol, (column, sdk_row, ours)


def test_calib_has_isint_and_the_gt_names_runeval_reads(tmp_path):
    _write_scene(tmp_path / "s", 0)
    assert read_calib(tmp_path / "s" / "calib.txt")["isint"] == 0
    names = sorted(p.name for p in (tmp_path / "s").iterdir())
    assert names == ["calib.txt", "disp0GT.pfm", "disp0Noisy.pfm", "disp1GT.pfm", "im0.png", "im1.png",
                     "im1E.png", "im1L.png", "mask0nocc.png"]
    assert (tmp_path / "s" / "im1E.png").read_bytes() == (tmp_path / "s" / "im1.png").read_bytes()


@pytest.mark.parametrize("thresh", [0.5, 1.0, 2.0, 4.0])
def test_evaldisp_equals_middlebury_v3(middeval_sdk, tmp_path, thresh):
    scene = tmp_path / "trainingF" / "Synth"
    est = _write_scene(scene, 1)
    nonocc = _evaldisp(middeval_sdk, scene / "disp0Noisy.pfm", scene / "disp0GT.pfm", thresh, 32, 0,
                       scene / "mask0nocc.png")
    _assert_same(nonocc, _ours(est, scene, "nonocc", thresh))
    everything = _evaldisp(middeval_sdk, scene / "disp0Noisy.pfm", scene / "disp0GT.pfm", thresh, 32, 0)
    _assert_same(everything, _ours(est, scene, "all", thresh))
    assert nonocc[1] != everything[1]  # the mask matters on this fixture


def test_runeval_reads_the_folder_unmodified(middeval_sdk, tmp_path):
    """runeval (tcsh) takes ndisp and isint from calib.txt with awk and scores every
    disp0<method>.pfm against disp0GT.pfm inside mask0nocc.png."""
    ests = {name: _write_scene(tmp_path / "trainingF" / name, seed)
            for seed, name in enumerate(["SceneA", "SceneB"], 2)}
    out = subprocess.run(["tcsh", str(middeval_sdk / "runeval"), "-b", "F", "all", "2.0"], cwd=tmp_path,
                         capture_output=True, text=True, check=True).stdout
    rows = [line.split() for line in out.splitlines()[1:] if line.strip()]
    assert sorted((r[0], r[1]) for r in rows) == [("SceneA", "GT"), ("SceneA", "Noisy"),
                                                  ("SceneB", "GT"), ("SceneB", "Noisy")]
    for row in rows:
        scene = tmp_path / "trainingF" / row[0]
        if row[1] == "GT":
            assert [float(v) for v in row[3:]] == [0.0, 0.0, 0.0, 0.0]
        else:
            _assert_same([float(v) for v in row[2:]], _ours(ests[row[0]], scene, "nonocc", 2.0))


def test_computemask_reads_our_pfms(middeval_sdk, tmp_path):
    """computemask's left-right check on disp0GT.pfm/disp1GT.pfm agrees with mask0nocc.png on
    which pixels have ground truth, and on visibility away from its 1 px rounding."""
    scene = tmp_path / "s"
    _write_scene(scene, 3)
    done = subprocess.run([str(middeval_sdk / "code" / "computemask"), str(scene / "disp0GT.pfm"),
                           str(scene / "disp1GT.pfm"), "-1", str(tmp_path / "mask.png")],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    theirs, ours = read_image(tmp_path / "mask.png"), read_image(scene / "mask0nocc.png")
    np.testing.assert_array_equal(theirs == 0, ours == 0)
    assert np.mean(theirs == ours) > 0.97
    assert re.match(r"thresh=1", done.stdout)


@pytest.mark.gl
def test_runeval_walks_a_dataset_directory_as_it_is(middeval_sdk, renderer, tmp_path):
    """A dataset written by run_dataset: runeval run in DIR/MiddEval3 finds every sample in
    trainingF/ and nothing else (the header, manifests and records sit outside)."""
    from matcher.io import read_pfm, write_pfm
    from synth.dataset.config.parse import loads_config
    from synth.dataset.run import run_dataset

    out = tmp_path / "ds"
    run_dataset(loads_config("seed = 2\ncount = 2\n[rig]\nwidth = 64\nheight = 48\n[scene]\n"
                             'base = "boxes"\n'), out=out, progress=False)
    root = out / "MiddEval3"
    rng = np.random.default_rng(0)
    for scene in sorted((root / "trainingF").iterdir()):
        gt = read_pfm(scene / "disp0GT.pfm")
        write_pfm(scene / "disp0Noisy.pfm", np.where(np.isfinite(gt), gt + rng.normal(
            0, 2.0, gt.shape), np.inf).astype(np.float32))
    result = subprocess.run(["tcsh", str(middeval_sdk / "runeval"), "-b", "F", "all", "2.0"],
                            cwd=root, capture_output=True, text=True, check=True).stdout
    rows = [line.split() for line in result.splitlines()[1:] if line.strip()]
    assert sorted((r[0], r[1]) for r in rows) == [("000000", "GT"), ("000000", "Noisy"),
                                                  ("000001", "GT"), ("000001", "Noisy")]
    for row in rows:
        if row[1] == "GT":
            assert [float(v) for v in row[3:]] == [0.0, 0.0, 0.0, 0.0]
        else:
            est = read_pfm(root / "trainingF" / row[0] / "disp0Noisy.pfm")
            _assert_same([float(v) for v in row[2:]],
                         _ours(est, root / "trainingF" / row[0], "nonocc", 2.0))
