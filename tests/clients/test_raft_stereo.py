"""RAFT-Stereo's own loaders (``core/stereo_datasets.py``, ``core/utils/frame_utils.py``, unmodified in
``../shared/clients/raft_stereo``) list and read datasets made by ``run_dataset`` as they are.

RAFT-Stereo imports torch; only its tensor plumbing is faked here (``torch.from_numpy`` and the
few tensor methods ``StereoDataset.__getitem__`` calls, the ``Dataset`` base class, and its
augmentor module, which imports torchvision): the file finding and every reader are RAFT's.
"""

from __future__ import annotations

import sys
import types
from pathlib import Path

import numpy as np
import pytest

from matcher.io import load_kitti_2015, load_middlebury_2014
from synth.dataset.config import loads_config
from synth.dataset.run import run_dataset

CONFIG = """\
name = "raft"
seed = 5
count = 3

[rig]
width = 64
height = 48

[scene]
base = {choice = ["fronto_plane", "boxes", "flying"]}
occluders = {uniform = [0, 2]}
"""

# RAFT's readPFM never closes its file (a ResourceWarning, raised when the file object is
# collected) and its Middlebury reader calls imageio's v2 imread: third-party warnings.
pytestmark = [pytest.mark.filterwarnings("ignore::ResourceWarning"),
              pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning"),
              pytest.mark.filterwarnings("ignore:Starting with ImageIO v3:DeprecationWarning")]


class _Tensor(np.ndarray):
    """The methods of a torch tensor that RAFT's ``StereoDataset.__getitem__`` calls."""

    def permute(self, *dims: int) -> _Tensor:
        return np.transpose(self, dims).view(_Tensor)

    def float(self) -> _Tensor:
        return self.astype(np.float32).view(_Tensor)

    def abs(self) -> _Tensor:
        return np.abs(self).view(_Tensor)


def _fake_modules() -> dict[str, types.ModuleType]:
    torch = types.ModuleType("torch")
    torch.from_numpy = lambda a: np.asarray(a).view(_Tensor)
    utils = types.ModuleType("torch.utils")
    data = types.ModuleType("torch.utils.data")
    data.Dataset = type("Dataset", (), {})
    data.get_worker_info = lambda: None
    nn = types.ModuleType("torch.nn")
    functional = types.ModuleType("torch.nn.functional")
    torch.utils, utils.data, torch.nn, nn.functional = utils, data, nn, functional
    augmentor = types.ModuleType("core.utils.augmentor")
    augmentor.FlowAugmentor = augmentor.SparseFlowAugmentor = None  # only used with crop_size
    return {"torch": torch, "torch.utils": utils, "torch.utils.data": data, "torch.nn": nn,
            "torch.nn.functional": functional, "core.utils.augmentor": augmentor}


@pytest.fixture
def raft(clients_dir: Path, monkeypatch: pytest.MonkeyPatch):
    """RAFT-Stereo's ``core.stereo_datasets`` and ``core.utils.frame_utils`` with torch faked."""
    root = clients_dir / "raft_stereo"
    if not (root / "core" / "stereo_datasets.py").is_file():
        pytest.fail(f"{root}/core/stereo_datasets.py is missing from the clients folder")
    import cv2

    before = set(sys.modules)
    # frame_utils sets OpenCV's global thread count and OpenCL switch at import: restored after,
    # since the matcher's Canny-versus-OpenCV tests fail after it otherwise (seen in the full suite)
    threads, opencl = cv2.getNumThreads(), cv2.ocl.useOpenCL()
    for name, module in _fake_modules().items():
        monkeypatch.setitem(sys.modules, name, module)
    monkeypatch.syspath_prepend(str(root))
    import core.stereo_datasets as datasets  # noqa: PLC0415 (RAFT's module, found on sys.path)
    from core.utils import frame_utils  # noqa: PLC0415

    yield datasets, frame_utils
    cv2.setNumThreads(threads)
    cv2.ocl.setUseOpenCL(opencl)
    for name in set(sys.modules) - before:
        if name == "core" or name.startswith("core."):
            del sys.modules[name]


@pytest.mark.gl
def test_raft_middlebury_loader_lists_and_reads_our_dataset(raft, renderer, tmp_path):
    datasets, frame_utils = raft
    out = tmp_path / "ds"
    run_dataset(loads_config(CONFIG), out=out, progress=False)
    loader = datasets.Middlebury(None, root=str(out), split="F")
    assert len(loader) == 3
    scenes = out / "MiddEval3" / "trainingF"
    assert [p[0] for p in loader.image_list] == [str(scenes / f"{i:06d}" / "im0.png")
                                                 for i in range(3)]
    for i in range(3):
        ours = load_middlebury_2014(scenes / f"{i:06d}")
        paths, img1, img2, flow, valid = loader[i]
        assert paths[2] == str(scenes / f"{i:06d}" / "disp0GT.pfm")
        left = ours.left if ours.left.ndim == 3 else np.repeat(ours.left[..., None], 3, axis=2)
        right = ours.right if ours.right.ndim == 3 else np.repeat(ours.right[..., None], 3, axis=2)
        np.testing.assert_array_equal(np.transpose(img1, (1, 2, 0)), left)
        np.testing.assert_array_equal(np.transpose(img2, (1, 2, 0)), right)
        # RAFT's flow is -disparity; its valid is mask0nocc == 255
        np.testing.assert_array_equal(-flow[0], ours.disp_left.astype(np.float32))
        np.testing.assert_array_equal(valid.astype(bool), ours.mask_left == 255)
        disp, nocc = frame_utils.readDispMiddlebury(paths[2])
        np.testing.assert_array_equal(disp, ours.disp_left)
        np.testing.assert_array_equal(nocc, ours.mask_left == 255)
        np.testing.assert_array_equal(frame_utils.readPFM(str(scenes / f"{i:06d}" / "disp1GT.pfm")),
                                      ours.disp_right)


@pytest.mark.gl
def test_raft_kitti_loader_lists_and_reads_our_dataset(raft, renderer, tmp_path):
    datasets, frame_utils = raft
    out = tmp_path / "kitti"
    run_dataset(loads_config(CONFIG), out=out, fmt="kitti", progress=False)
    loader = datasets.KITTI(None, root=str(out), image_set="training")
    assert len(loader) == 3
    for i in range(3):
        ours = load_kitti_2015(out / "training", i)
        paths, img1, img2, flow, valid = loader[i]
        assert paths == [str(out / "training" / sub / f"{i:06d}_10.png")
                         for sub in ("image_2", "image_3", "disp_occ_0")]
        np.testing.assert_array_equal(np.transpose(img1, (1, 2, 0)), ours.left)
        np.testing.assert_array_equal(np.transpose(img2, (1, 2, 0)), ours.right)
        disp, ok = frame_utils.readDispKITTI(paths[2])
        np.testing.assert_array_equal(ok, np.isfinite(ours.disp_left))
        np.testing.assert_array_equal(disp[ok], ours.disp_left[ok])
        np.testing.assert_array_equal(-flow[0][ok], ours.disp_left[ok].astype(np.float32))
        np.testing.assert_array_equal(valid.astype(bool), ok)
