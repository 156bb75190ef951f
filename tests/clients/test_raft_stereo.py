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

from matcher.io import load_kitti_2015, load_middlebury_2014, read_image
from synth.dataset.config.parse import loads_config
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
#: Real im1E.png / im1L.png (else they are copies of im1.png), for RAFT's split "2014".
VARIANTS = "exposure_variant = 2.0\nlighting_variant = 30.0\n"

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


def _rgb(image: np.ndarray) -> np.ndarray:
    """A grey image as RAFT's ``StereoDataset.__getitem__`` returns it (tiled to 3 channels)."""
    return image if image.ndim == 3 else np.repeat(image[..., None], 3, axis=2)


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
@pytest.mark.parametrize("image_deflate", [None, "stored"])
def test_raft_middlebury_loader_lists_and_reads_our_dataset(raft, renderer, tmp_path,
                                                            image_deflate):
    datasets, frame_utils = raft
    out = tmp_path / "ds"
    config = CONFIG if image_deflate is None else CONFIG.replace(
        "count = 3\n", f'count = 3\nimage_deflate = "{image_deflate}"\n')
    run_dataset(loads_config(config), out=out, progress=False)
    assert loads_config(config).image_deflate == image_deflate
    loader = datasets.Middlebury(None, root=str(out), split="F")
    assert len(loader) == 3
    scenes = out / "MiddEval3" / "trainingF"
    assert [p[0] for p in loader.image_list] == [str(scenes / f"{i:06d}" / "im0.png")
                                                 for i in range(3)]
    for i in range(3):
        ours = load_middlebury_2014(scenes / f"{i:06d}")
        paths, img1, img2, flow, valid = loader[i]
        assert paths[2] == str(scenes / f"{i:06d}" / "disp0GT.pfm")
        np.testing.assert_array_equal(np.transpose(img1, (1, 2, 0)), _rgb(ours.left))
        np.testing.assert_array_equal(np.transpose(img2, (1, 2, 0)), _rgb(ours.right))
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


def _check_2014_scenes(loader, frame_utils, scenes: list[Path]) -> None:
    """RAFT's ``Middlebury(split="2014")`` over ``scenes``: three pairs per scene (``im0.png``
    with ``im1E.png``, ``im1L.png``, ``im1.png``, in that order), ``disp0.pfm`` for each, and
    every array it returns equal to ours. Its ``valid`` is ``disp0.pfm < 1e3``: every pixel with
    ground truth, the occluded ones included (``inf``, no ground truth, is invalid), as for the
    real 2014 scenes."""
    assert sorted(Path(pair[0]).parent for pair in loader.image_list[::3]) == sorted(scenes)
    assert len(loader) == 3 * len(scenes)
    for k, (pair, disp_path) in enumerate(zip(loader.image_list, loader.disparity_list)):
        scene = Path(pair[0]).parent
        assert pair == [str(scene / "im0.png"), str(scene / f"im1{('E', 'L', '')[k % 3]}.png")]
        assert disp_path == str(scene / "disp0.pfm")
        ours = load_middlebury_2014(scene)
        paths, img1, img2, flow, valid = loader[k]
        assert paths == [*pair, disp_path]
        np.testing.assert_array_equal(np.transpose(img1, (1, 2, 0)), _rgb(ours.left))
        np.testing.assert_array_equal(np.transpose(img2, (1, 2, 0)),
                                      _rgb(read_image(scene / Path(pair[1]).name)))
        # RAFT's flow is -disparity (inf -> -inf where there is no ground truth)
        np.testing.assert_array_equal(-flow[0], ours.disp_left.astype(np.float32))
        np.testing.assert_array_equal(valid.astype(bool), np.isfinite(ours.disp_left))
        assert valid.astype(bool)[ours.mask_left == 128].all()  # occluded, with ground truth
        disp, ok = frame_utils.readDispMiddlebury(disp_path)
        np.testing.assert_array_equal(disp, ours.disp_left)
        np.testing.assert_array_equal(ok, np.isfinite(ours.disp_left))
        np.testing.assert_array_equal(frame_utils.readPFM(str(scene / "disp1.pfm")),
                                      ours.disp_right)
    for scene in scenes:  # the variants are the rendered ones, not copies of im1.png
        right = read_image(scene / "im1.png")
        for name in ("im1E.png", "im1L.png"):
            assert not np.array_equal(read_image(scene / name), right), (scene, name)


@pytest.mark.gl
def test_raft_middlebury_2014_loader_lists_and_reads_our_dataset(raft, renderer, tmp_path):
    datasets, frame_utils = raft
    out = tmp_path / "ds"
    run_dataset(loads_config(CONFIG + VARIANTS), out=out, fmt="middlebury2014", progress=False)
    loader = datasets.Middlebury(None, root=str(out), split="2014")
    _check_2014_scenes(loader, frame_utils, [out / "2014" / f"{i:06d}" for i in range(3)])


@pytest.mark.gl
def test_raft_middlebury_2014_loader_reads_a_rendered_pair(raft, renderer, tmp_path):
    """``stereoforge render --format middlebury2014 --out ROOT/2014/<scene>`` is one scene folder
    of the 2014 archives: ``Middlebury(root=ROOT, split="2014")`` loads it as it is."""
    from click.testing import CliRunner

    from synth.cli import main

    import dataclasses

    from scenes import dumps_toml, get_preset

    datasets, frame_utils = raft
    plane = get_preset("fronto_plane")
    card = tmp_path / "card.toml"  # a plane smaller than the view: pixels without ground truth
    card.write_text(dumps_toml(dataclasses.replace(
        plane, name="card", objects=(dataclasses.replace(plane.objects[0], size=(1.2, 0.8)),))))
    root = tmp_path / "Middlebury"
    scenes = {"boxes": root / "2014" / "boxes-perfect", str(card): root / "2014" / "card-perfect"}
    for scene, folder in scenes.items():
        result = CliRunner().invoke(main, [
            "render", scene, "--out", str(folder), "--format", "middlebury2014", "--width", "64",
            "--height", "48", "--exposure-variant", "2", "--lighting-variant", "30"])
        assert result.exit_code == 0, result.output
    assert not np.isfinite(load_middlebury_2014(scenes[str(card)]).disp_left).all()
    loader = datasets.Middlebury(None, root=str(root), split="2014")
    _check_2014_scenes(loader, frame_utils, list(scenes.values()))


@pytest.mark.gl
@pytest.mark.slow
def test_raft_sceneflow_loader_lists_and_reads_our_sceneflow_layout(raft, training_layouts):
    """RAFT-Stereo's ``SceneFlowDatasets`` (root ``OUT/SceneFlow``) over a 24-sample 960x540
    ``--format sceneflow`` dataset: both ``dstype``s list the 21 TRAIN samples, ``things_test``
    the 3 TEST ones (``index % 25 >= 21``), and every image and disparity it returns is bit for
    bit the default layout's (``frames_finalpass``: the config's images; ``frames_cleanpass``:
    the same config without its photometric models); a RAFT-style masked loss on a batch is
    finite."""
    from synth.formats.sceneflow import place

    datasets, frame_utils = raft
    root = training_layouts("sceneflow") / "SceneFlow"
    references = {"frames_finalpass": training_layouts("middlebury"),
                  "frames_cleanpass": training_layouts("middlebury-clean")}
    by_path = {}
    for index in range(24):
        split, letter, sequence, frame = place(index)
        by_path[(split, f"{letter}/{sequence:04d}/left/{frame:04d}.png")] = index
    for dstype, reference in references.items():
        for things_test, split, count in ((False, "TRAIN", 21), (True, "TEST", 3)):
            loader = datasets.SceneFlowDatasets(None, root=str(root), dstype=dstype,
                                                things_test=things_test)
            assert len(loader) == count
            flows, valids = [], []
            for k in range(count):
                paths, img1, img2, flow, valid = loader[k]
                rel = Path(paths[0]).relative_to(root / "FlyingThings3D" / dstype / split)
                index = by_path[(split, rel.as_posix())]
                scene = reference / "MiddEval3" / "trainingF" / f"{index:06d}"
                ours = load_middlebury_2014(scene)
                assert paths[1] == paths[0].replace("/left/", "/right/")
                np.testing.assert_array_equal(np.transpose(img1, (1, 2, 0)), ours.left)
                np.testing.assert_array_equal(np.transpose(img2, (1, 2, 0)), ours.right)
                gt = load_middlebury_2014(references["frames_finalpass"] / "MiddEval3" /
                                          "trainingF" / f"{index:06d}")  # the same geometry
                np.testing.assert_array_equal(-flow[0], gt.disp_left)  # inf stays inf
                np.testing.assert_array_equal(valid.astype(bool), np.isfinite(gt.disp_left))
                assert valid.astype(bool).any()
                right = paths[2].replace("/left/", "/right/")
                np.testing.assert_array_equal(frame_utils.readPFM(right), gt.disp_right)
                flows.append(flow)
                valids.append(valid)
            # RAFT-Stereo's sequence_loss: |prediction - flow| over valid (>= 0.5) pixels
            flow, valid = np.stack(flows), np.stack(valids)
            prediction = np.zeros_like(flow)
            loss = np.abs(prediction - flow)[np.broadcast_to(valid[:, None] >= 0.5, flow.shape)]
            assert loss.size and np.isfinite(loss).all() and np.isfinite(loss.mean())


@pytest.mark.gl
def test_raft_sceneflow_loader_masks_pixels_without_ground_truth(raft, renderer, tmp_path):
    """A SceneFlow pair with pixels without ground truth (``inf`` in both PFMs): RAFT-Stereo's
    loader reads them as invalid (``|flow| < 512`` is false), and its masked loss stays finite."""
    import dataclasses

    from scenes import get_preset
    from synth.camera.rig import StereoRig
    from synth.pair import render_pair
    from synth.write.export import write_pair

    datasets, _ = raft
    pair = render_pair(get_preset("boxes", seed=2), StereoRig.default(160, 120), renderer=renderer)
    hole = np.zeros(pair.disp_left.shape, bool)
    hole[:10, :40] = True
    pair = dataclasses.replace(pair, disp_left=np.where(hole, np.inf, pair.disp_left),
                               disp_right=np.where(hole, np.inf, pair.disp_right),
                               mask_left=np.where(hole, 0, pair.mask_left).astype(np.uint8))
    write_pair(pair, tmp_path, scene=get_preset("boxes", seed=2), seed=2, fmt="sceneflow",
               index=21, preview=False, fsync=False)  # sample 21: TEST/A/0000/left/0000.png
    loader = datasets.SceneFlowDatasets(None, root=str(tmp_path / "SceneFlow"),
                                        dstype="frames_finalpass", things_test=True)
    assert len(loader) == 1
    _, _, _, flow, valid = loader[0]
    np.testing.assert_array_equal(valid.astype(bool), ~hole)
    assert np.isinf(flow[0][hole]).all()
    loss = np.abs(np.zeros_like(flow) - flow)[valid[None] >= 0.5]
    assert loss.size == (~hole).sum() and np.isfinite(loss).all()
