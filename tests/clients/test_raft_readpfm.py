"""RAFT-Stereo's ``readPFM`` (``core/utils/frame_utils.py`` of ``../shared/clients/raft_stereo``,
unmodified, loaded by file path with nothing faked) reads the disparity PFMs of
:func:`matcher.io.encode_pfm` bit for bit, ``inf`` included.

``readPFM`` reads every byte after the header as data (``np.fromfile``) and reshapes it, so the
header must be exactly ``Pf\\nW H\\n-1\\n`` and nothing may follow the data: what the SceneFlow
layout's disparity files need.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from matcher.io import encode_pfm

# readPFM never closes its file: a ResourceWarning when the file object is collected.
pytestmark = [pytest.mark.filterwarnings("ignore::ResourceWarning"),
              pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")]


@pytest.fixture
def frame_utils(clients_dir: Path):
    path = clients_dir / "raft_stereo" / "core" / "utils" / "frame_utils.py"
    if not path.is_file():
        pytest.fail(f"{path} is missing from the clients folder")
    import cv2

    # frame_utils sets OpenCV's global thread count and OpenCL switch at import: restored after
    threads, opencl = cv2.getNumThreads(), cv2.ocl.useOpenCL()
    spec = importlib.util.spec_from_file_location("raft_frame_utils", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    yield module
    cv2.setNumThreads(threads)
    cv2.ocl.setUseOpenCL(opencl)


def test_raft_readpfm_reads_our_disparity_pfm_bit_exactly(frame_utils, tmp_path):
    rng = np.random.default_rng(2)
    disp = rng.uniform(0.0, 300.0, (27, 48)).astype(np.float32)
    disp[3:9, 5:20] = np.inf  # no ground truth
    data = encode_pfm(disp)
    assert data.startswith(b"Pf\n48 27\n-1\n") and len(data) == len(b"Pf\n48 27\n-1\n") + 4 * disp.size
    path = tmp_path / "0006.pfm"
    path.write_bytes(data)
    out = frame_utils.readPFM(str(path))
    assert out.shape == disp.shape
    np.testing.assert_array_equal(np.asarray(out, np.float32).view(np.uint32), disp.view(np.uint32))
