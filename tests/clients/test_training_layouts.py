"""The training codebases' own file finding and decoding, line for line, over our
``--format sceneflow``, ``crestereo`` and ``fsd`` datasets.

RAFT-Stereo's loader runs unmodified from ``../shared/clients`` (tests/clients/test_raft_stereo.py).
The others (IGEV-Stereo, IGEV++, unimatch, OpenStereo, GwcNet/ACVNet/CFNet, CREStereo,
FoundationStereo, torchvision) import torch, CUDA extensions or their whole training stack, and are
not in the clients folder; each function below repeats, quoted, the lines of that codebase that
find a sample's files and decode its disparity (the repository and file are named), so what we
write is checked against what they do: every sample found, every path existing, the pixels and the
ground truth equal to the default layout's within the layout's quantum. docs/formats.md gives the
root each takes.
"""

from __future__ import annotations

import os
import os.path as osp
from glob import glob
from pathlib import Path

import cv2
import numpy as np
import pytest

from matcher.io import encode_jpeg, load_middlebury_2014, read_image, read_pfm
from synth.formats.base import JPEG_QUALITY

pytestmark = [pytest.mark.gl, pytest.mark.slow]


def _reference(root: Path, index: int):
    return load_middlebury_2014(root / "MiddEval3" / "trainingF" / f"{index:06d}")


def _as_jpeg(image: np.ndarray) -> np.ndarray:
    data = np.frombuffer(encode_jpeg(image, quality=JPEG_QUALITY), np.uint8)
    return cv2.imdecode(data, cv2.IMREAD_COLOR)[..., ::-1]


def _sceneflow_indices() -> dict[str, int]:
    """Left image path (relative to ``SceneFlow/FlyingThings3D/<pass>``) -> sample index
    (:func:`synth.formats.sceneflow.place`)."""
    from synth.formats.sceneflow import place

    out = {}
    for index in range(24):
        split, letter, sequence, frame = place(index)
        out[f"{split}/{letter}/{sequence:04d}/left/{frame:04d}.png"] = index
    return out


def _check_sceneflow(triples, things: Path, reference: Path, dstype: str) -> None:
    """Each (left, right, disparity) path names a sample's files of pass ``dstype``: the images
    and the disparity are the reference's."""
    indices = _sceneflow_indices()
    assert triples
    for left, right, disp in triples:
        index = indices[Path(left).relative_to(things / dstype).as_posix()]
        ours = _reference(reference, index)
        np.testing.assert_array_equal(read_image(left), ours.left)
        np.testing.assert_array_equal(read_image(right), ours.right)
        np.testing.assert_array_equal(read_pfm(disp), ours.disp_left)


def test_igev_stereo_sceneflow(training_layouts):
    """IGEV-Stereo (gangweiX/IGEV, IGEV-Stereo/core/stereo_datasets.py, ``SceneFlowDatasets``):
    one merged tree, ``root = OUT/SceneFlow/FlyingThings3D``, finalpass, all of TEST."""
    things = training_layouts("sceneflow") / "SceneFlow" / "FlyingThings3D"
    root, dstype = str(things), "frames_finalpass"
    for split, count in (("TRAIN", 21), ("TEST", 3)):
        left_images = sorted(glob(osp.join(root, dstype, split, '*/*/left/*.png')))
        right_images = [im.replace('left', 'right') for im in left_images]
        disparity_images = [im.replace(dstype, 'disparity').replace('.png', '.pfm')
                            for im in left_images]
        assert len(left_images) == count
        _check_sceneflow(list(zip(left_images, right_images, disparity_images)), things,
                         training_layouts("middlebury"), dstype)
    # its Monkaa and Driving globs (depth 1 and 3 under TRAIN) find nothing of ours
    assert not glob(osp.join(root, dstype, "TRAIN", '*/left/*.png'))
    assert not glob(osp.join(root, dstype, "TRAIN", '*/*/*/left/*.png'))


def test_unimatch_flyingthings3d(training_layouts):
    """unimatch (autonomousvision/unimatch, dataloader/stereo/datasets.py, ``FlyingThings3D``):
    ``data_dir = OUT/SceneFlow/FlyingThings3D``; the right image by its ``/left/`` segment, the
    disparity by ``replace(split, 'disparity')``; valid ``(gt > 0) & (gt < 400)``."""
    things = training_layouts("sceneflow") / "SceneFlow" / "FlyingThings3D"
    data_dir = str(things)
    for split in ("frames_cleanpass", "frames_finalpass"):
        for mode, count in (("TRAIN", 21), ("TEST", 3)):
            left_files = sorted(glob(data_dir + '/' + split + '/' + mode + '/*/*/left/*.png'))
            assert len(left_files) == count
            triples = [(name, name.replace('/left/', '/right/'),
                        name.replace(split, 'disparity')[:-4] + '.pfm') for name in left_files]
            reference = training_layouts("middlebury" if split == "frames_finalpass"
                                         else "middlebury-clean")
            for left, right, disp in triples:
                gt = read_pfm(disp)
                valid = (gt > 0) & (gt < 400)
                assert valid.any() and np.isfinite(gt[valid]).all()
            if split == "frames_finalpass":
                _check_sceneflow(triples, things, reference, split)
            else:  # the clean pass: the images of the config without its photometric models
                indices = _sceneflow_indices()
                for left, right, _ in triples:
                    ours = _reference(reference, indices[Path(left).relative_to(
                        things / split).as_posix()])
                    np.testing.assert_array_equal(read_image(left), ours.left)
                    np.testing.assert_array_equal(read_image(right), ours.right)


def test_gwcnet_and_openstereo_list_files(training_layouts):
    """GwcNet / ACVNet / CFNet (``datasets/sceneflow_dataset.py``: ``line.split()`` and
    ``os.path.join(self.datapath, x)``) and OpenStereo (``x.strip().split(' ')``, asserting no
    NaN) with ``datapath = OUT/SceneFlow`` and our list files; GwcNet's test crop (bottom-right
    960x512) fits 960x540."""
    sf = training_layouts("sceneflow") / "SceneFlow"
    things = sf / "FlyingThings3D"
    for pass_ in ("cleanpass", "finalpass"):
        for split, count in (("train", 21), ("test", 3)):
            lines = (sf / f"sceneflow_{pass_}_{split}.txt").read_text().splitlines()
            assert len(lines) == count and all(line.count(" ") == 2 for line in lines)
            triples = []
            for line in lines:
                left, right, disp = [os.path.join(str(sf), x) for x in line.strip().split(' ')]
                gt = read_pfm(disp)
                assert not np.isnan(gt).any()  # OpenStereo asserts it
                h, w = gt.shape
                assert gt[h - 512:h, w - 960:w].shape == (512, 960)
                triples.append((left, right, disp))
            if pass_ == "finalpass":
                _check_sceneflow(triples, things, training_layouts("middlebury"),
                                 "frames_finalpass")


def test_torchvision_sceneflow_stereo(training_layouts):
    """torchvision (torchvision/datasets/_stereo_matching.py, ``SceneFlowStereo(root=OUT,
    variant="FlyingThings3D")``): left and right images and left and right PFMs paired by
    sorted order, TRAIN and TEST together; the counts must match."""
    root = Path(training_layouts("sceneflow")) / "SceneFlow" / "FlyingThings3D"
    prefix = Path("*") / "*" / "*"
    for p in ("frames_cleanpass", "frames_finalpass"):
        left = sorted(glob(str(root / p / prefix / "left" / "*.png")))
        right = sorted(glob(str(root / p / prefix / "right" / "*.png")))
        dleft = sorted(glob(str(root / "disparity" / prefix / "left" / "*.pfm")))
        dright = sorted(glob(str(root / "disparity" / prefix / "right" / "*.pfm")))
        assert len(left) == len(right) == len(dleft) == len(dright) == 24
        for a, b, c, d in zip(left, right, dleft, dright):  # pairing by order is by sample
            assert Path(a).parts[-5:-2] == Path(b).parts[-5:-2] == Path(c).parts[-5:-2]
            assert Path(a).stem == Path(b).stem == Path(c).stem == Path(d).stem
            assert np.isfinite(np.abs(read_pfm(d))).any()


def _check_crestereo(stems, reference: Path, *, right_disparity: bool) -> None:
    from matcher.io import CRESTEREO_SCALE

    for stem in stems:
        index = int(Path(stem).name)
        ours = _reference(reference, index)
        np.testing.assert_array_equal(read_image(f"{stem}_left.jpg"), _as_jpeg(ours.left))
        np.testing.assert_array_equal(read_image(f"{stem}_right.jpg"), _as_jpeg(ours.right))
        views = (("left", ours.disp_left), ("right", ours.disp_right))
        for view, gt in views if right_disparity else views[:1]:
            # CREStereo's dataset.py: cv2.imread(path, cv2.IMREAD_UNCHANGED).astype(np.float32) / 32
            disp = cv2.imread(f"{stem}_{view}.disp.png", cv2.IMREAD_UNCHANGED).astype(np.float32)
            disp = disp / 32
            known = np.isfinite(gt)
            np.testing.assert_array_equal(disp > 0, known)  # 0 = no ground truth
            assert np.abs(disp[known] - gt[known]).max() <= 0.5 / CRESTEREO_SCALE + 1e-6


def test_crestereo_own_loader(training_layouts):
    """CREStereo (megvii-research/CREStereo, dataset.py): ``glob(root/**/*_left.jpg,
    recursive=True)``, the other files from ``path[:path.rfind('_')]``; the right disparity is
    read too."""
    root = training_layouts("crestereo") / "CREStereo"
    imgs = glob(os.path.join(str(root), "**/*_left.jpg"), recursive=True)
    assert len(imgs) == 8
    stems = [path[:path.rfind('_')] for path in imgs]
    _check_crestereo(stems, training_layouts("middlebury-small"), right_disparity=True)


def test_crestereo_in_unimatch_igevpp_torchvision(training_layouts):
    """unimatch's and IGEV++'s ``CREStereoDataset`` (three sorted globs ``root/*/*_left.jpg``,
    ``*_right.jpg``, ``*_left.disp.png``, zipped, counts equal) and torchvision's
    ``CREStereo(root=OUT)`` (the four subsets, each non-empty, left/right disparity pairs)."""
    out = training_layouts("crestereo")
    root = str(out / "CREStereo")
    image1_list = sorted(glob(os.path.join(root, '*/*_left.jpg')))
    image2_list = sorted(glob(os.path.join(root, '*/*_right.jpg')))
    disp_list = sorted(glob(os.path.join(root, '*/*_left.disp.png')))
    assert len(image1_list) == len(image2_list) == len(disp_list) == 8
    for a, b, c in zip(image1_list, image2_list, disp_list):
        assert a[:-len("_left.jpg")] == b[:-len("_right.jpg")] == c[:-len("_left.disp.png")]
    for d in ("shapenet", "reflective", "tree", "hole"):
        left = sorted(glob(str(out / "CREStereo" / d / "*_left.jpg")))
        right = sorted(glob(str(out / "CREStereo" / d / "*_right.jpg")))
        dleft = sorted(glob(str(out / "CREStereo" / d / "*_left.disp.png")))
        dright = sorted(glob(str(out / "CREStereo" / d / "*_right.disp.png")))
        assert left and len(left) == len(right) == len(dleft) == len(dright)
        # torchvision: np.asarray(Image.open(p), dtype=np.float32)[None] / 32.0
        from PIL import Image

        for p in dleft:
            disp = np.asarray(Image.open(p), dtype=np.float32)[None] / 32.0
            assert disp.shape[0] == 1 and (disp > 0).any()


def test_foundationstereo_fsd(training_layouts):
    """OpenStereo's FSD reader (``glob(root/*/dataset/data/)``, then ``left/rgb/*.jpg``; the
    right image by ``replace('left', 'right')`` and the disparity by ``replace('rgb',
    'disparity').replace('.jpg', '.png')``, both over the whole path) with ``root = OUT/FSD``,
    and FoundationStereo's ``depth_uint8_decoding`` (``R*255*255 + G*255 + B``, RGB order, /1000)."""
    import imageio.v2 as imageio

    from matcher.io import FSD_SCALE

    root = str(training_layouts("fsd") / "FSD")
    reference = training_layouts("middlebury-small")
    data_dirs = glob(os.path.join(root, '*/dataset/data/'))
    found = []
    for each_data_dir in data_dirs:
        left_images = glob(os.path.join(each_data_dir, 'left/rgb/*.jpg'))
        for each in left_images:
            found.append({'left': each, 'right': each.replace('left', 'right'),
                          'disp': each.replace('rgb', 'disparity').replace('.jpg', '.png')})
    assert len(found) == 8
    for item in found:
        index = int(Path(item['left']).stem)  # scene 0000: frame = index
        ours = _reference(reference, index)
        np.testing.assert_array_equal(imageio.imread(item['left']), _as_jpeg(ours.left))
        np.testing.assert_array_equal(imageio.imread(item['right']), _as_jpeg(ours.right))
        depth_uint8 = imageio.imread(item['disp']).astype(np.float64)
        out = depth_uint8[..., 0] * 255 * 255 + depth_uint8[..., 1] * 255 + depth_uint8[..., 2]
        disp = out / 1000
        known = np.isfinite(ours.disp_left)
        np.testing.assert_array_equal(disp > 0, known)
        assert np.abs(disp[known] - ours.disp_left[known]).max() <= 0.5 / FSD_SCALE + 1e-6
