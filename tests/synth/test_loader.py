"""StereoDataset: items against the files, splits, the previous layout, and the protocol a torch
DataLoader uses (len, integer indexing, pickling into worker processes) without torch."""

from __future__ import annotations

import json
import multiprocessing
import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

from matcher.io import load_kitti_2015, load_middlebury_2014
from stereoforge.errors import DatasetError
from synth import StereoDataset
from synth.dataset.config.parse import loads_config
from synth.dataset.loader import is_validation
from synth.dataset.run import read_manifest, run_dataset

CONFIG = """\
name = "loader"
seed = 3
count = 40

[rig]
width = 40
height = 30

[scene]
base = {choice = ["fronto_plane", "boxes"]}
occluders = {uniform = [0, 2]}
"""


@pytest.fixture(scope="module")
def datasets(tmp_path_factory, renderer) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("loader")
    cfg = loads_config(CONFIG)
    out = {}
    for fmt in ("middlebury", "middlebury2014", "kitti"):
        out[fmt] = root / fmt
        run_dataset(cfg, out=out[fmt], fmt=fmt, count=40 if fmt == "middlebury" else 4,
                    progress=False)
    return out


def _getitem(args: tuple[bytes, int]) -> dict:
    data, i = args
    return pickle.loads(data)[i]


@pytest.mark.gl
def test_middlebury_items_are_the_files(datasets):
    data = StereoDataset(datasets["middlebury"])
    assert len(data) == 40 and data.indices == tuple(range(40))
    item = data[5]
    ours = load_middlebury_2014(datasets["middlebury"] / "MiddEval3" / "trainingF" / "000005")
    np.testing.assert_array_equal(item["left"], ours.left)
    np.testing.assert_array_equal(item["right"], ours.right)
    np.testing.assert_array_equal(item["disp"], ours.disp_left)
    np.testing.assert_array_equal(item["disp_right"], ours.disp_right)
    np.testing.assert_array_equal(item["valid"], np.isfinite(ours.disp_left))
    np.testing.assert_array_equal(item["occlusion"], ours.mask_left == 128)
    assert item["left"].dtype == np.uint8 and item["disp"].dtype == np.float32
    assert item["valid"].dtype == item["occlusion"].dtype == np.bool_
    rig = json.loads((datasets["middlebury"] / "MiddEval3" / "trainingF" / "000005"
                      / "scene.json").read_text())["rig"]
    assert item["calib"] == {k: rig[k] for k in ("fx", "fy", "cx", "cy", "baseline")}
    assert int(item["index"]) == 5 and int(item["seed"]) == read_manifest(datasets["middlebury"])[5]["seed"]
    np.testing.assert_array_equal(data[-1]["disp"], data[39]["disp"])
    with pytest.raises(IndexError):
        data[40]
    with pytest.raises(TypeError):
        data["5"]


@pytest.mark.gl
def test_kitti_items_are_the_files(datasets):
    data = StereoDataset(datasets["kitti"])
    assert len(data) == 4
    ours = load_kitti_2015(datasets["kitti"] / "training", 2)
    item = data[2]
    np.testing.assert_array_equal(item["left"], ours.left)
    np.testing.assert_array_equal(item["disp"], ours.disp_left)
    np.testing.assert_array_equal(item["occlusion"], ours.mask_left == 128)
    assert "disp_right" not in item


# a wide view (fx = 18 px) of boxes: most pixels see nothing (no ground truth, mask 0); the long
# baseline gives the boxes occluded pixels (mask 128)
_OPEN_VIEW = """\
name = "open-view"
seed = 1
count = 1

[rig]
width = 40
height = 30
fx = 18.0
baseline = 2.0

[scene]
base = "boxes"
"""


@pytest.mark.gl
@pytest.mark.parametrize("fmt", ["middlebury", "kitti"])
def test_occlusion_holds_the_occluded_pixels_only_not_those_without_ground_truth(tmp_path, fmt,
                                                                                renderer):
    run_dataset(loads_config(_OPEN_VIEW), out=tmp_path / fmt, fmt=fmt, progress=False)
    item = StereoDataset(tmp_path / fmt)[0]
    assert (~item["valid"]).sum() > 100 and item["occlusion"].sum() > 10  # both kinds present
    assert not (item["occlusion"] & ~item["valid"]).any()
    sample = (load_middlebury_2014(tmp_path / fmt / "MiddEval3" / "trainingF" / "000000")
              if fmt == "middlebury" else load_kitti_2015(tmp_path / fmt / "training", 0))
    np.testing.assert_array_equal(item["occlusion"], sample.mask_left == 128)


@pytest.mark.gl
def test_middlebury_2014_items_are_the_middeval3_items(datasets):
    """The same config in the 2014 layout (``2014/NNNNNN/disp0.pfm``): the same arrays."""
    data, twin = StereoDataset(datasets["middlebury2014"]), StereoDataset(datasets["middlebury"])
    assert len(data) == 4 and data.format == "middlebury2014"
    for i in range(4):
        item, theirs = data[i], twin[i]
        assert sorted(item) == sorted(theirs)
        for key, value in item.items():
            if key == "calib":
                assert value == theirs[key]
            else:
                np.testing.assert_array_equal(value, theirs[key])
                assert np.asarray(value).dtype == np.asarray(theirs[key]).dtype, key


@pytest.mark.gl
def test_train_and_val_split_the_samples_by_seed(datasets):
    records = read_manifest(datasets["middlebury"])
    train = StereoDataset(datasets["middlebury"], split="train", val_fraction=0.25)
    val = StereoDataset(datasets["middlebury"], split="val", val_fraction=0.25)
    assert sorted(train.indices + val.indices) == list(range(40))
    assert not set(train.indices) & set(val.indices)
    assert list(val.indices) == [r["index"] for r in records if r["seed"] < 0.25 * 2**63]
    assert 4 <= len(val) <= 16  # 10 expected of 40
    # a sample keeps its split when the dataset grows: the split depends on its seed only
    assert all(is_validation(r["seed"], 0.25) == (r["index"] in val.indices) for r in records)
    with pytest.raises(DatasetError, match="no complete sample in split 'val'"):
        StereoDataset(datasets["middlebury"], split="val", val_fraction=0.0)
    with pytest.raises(ValueError, match="split"):
        StereoDataset(datasets["middlebury"], split="test")


@pytest.mark.gl
@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_items_survive_pickling_into_worker_processes(datasets, method):
    data = StereoDataset(datasets["middlebury"], split="train")
    blob = pickle.dumps(data)
    ctx = multiprocessing.get_context(method)
    with ctx.Pool(2) as pool:
        items = pool.map(_getitem, [(blob, i) for i in (0, 3, len(data) - 1)])
    for i, item in zip((0, 3, len(data) - 1), items):
        here = data[i]
        assert sorted(item) == sorted(here)
        for key in ("left", "right", "disp", "valid", "occlusion"):
            np.testing.assert_array_equal(item[key], here[key])
    # what default_collate does with a batch: stack each key
    batch = {k: np.stack([data[i][k] for i in range(3)]) for k in ("left", "disp", "valid")}
    assert batch["left"].shape == (3, 30, 40, 3) and batch["disp"].shape == (3, 30, 40)


@pytest.mark.gl
def test_the_previous_layout_is_refused_with_the_upgrade_line(datasets, tmp_path):
    old = tmp_path / "old"
    shutil.copytree(datasets["middlebury"], old)
    os.replace(old / "MiddEval3" / "trainingF" / "000000", old / "000000")
    with pytest.raises(DatasetError, match=rf"stereoforge dataset --upgrade {old}"):
        StereoDataset(old)


def test_a_directory_without_dataset_is_refused(tmp_path):
    with pytest.raises(DatasetError, match="has no dataset.json"):
        StereoDataset(tmp_path)
