"""``image_deflate``: the images' PNGs of a dataset without compression (or with another
deflate), the same pixels; the masks, disparities and everything else unchanged."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from matcher.io import DEFLATES
from stereoforge.errors import ConfigError, ParameterError
from synth.dataset.compare import compare_datasets
from synth.dataset.config import keys as config_keys
from synth.dataset.config.parse import loads_config
from synth.dataset.run import run_dataset

CONFIG = """\
name = "tiny-deflate"
seed = 5
count = 3
preview = true

[rig]
width = 40
height = 30

[scene]
base = "flying"
texture = "noise"

[photometric]
noise_sigma = 1.0
"""


def _pixels(path: Path) -> np.ndarray:
    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def _with(deflate: str) -> str:
    return CONFIG.replace("preview = true\n", f'preview = true\nimage_deflate = "{deflate}"\n')


def test_config_choices_are_the_encoders_and_the_default_keeps_the_hash():
    assert config_keys.IMAGE_DEFLATES == DEFLATES
    plain, stored = loads_config(CONFIG), loads_config(_with("stored"))
    assert plain.image_deflate is None and "image_deflate" not in plain.to_dict()
    assert stored.image_deflate == "stored" and stored.to_dict()["image_deflate"] == "stored"
    assert stored.hash() != plain.hash()  # a resume with another encoding is refused
    with pytest.raises(ConfigError, match=r"image_deflate.*'stored'.*got 'zstd'"):
        loads_config(_with("zstd"))


@pytest.mark.gl
@pytest.mark.parametrize("fmt", ["middlebury", "kitti", "sceneflow"])
def test_stored_images_hold_the_same_pixels_and_nothing_else_changes(fmt, tmp_path, renderer):
    a, b = tmp_path / "default", tmp_path / "stored"
    run_dataset(loads_config(CONFIG), out=a, fmt=fmt, progress=False)
    run_dataset(loads_config(_with("stored")), out=b, fmt=fmt, progress=False)
    differences = compare_datasets(a, b)
    encoded = {d.path for d in differences if d.kind == "encoding"}
    other = [d for d in differences if d.kind not in ("encoding", "hashes")]
    # only the manifest differs in content (its configuration says image_deflate)
    assert {Path(d.path).name for d in other} == {"dataset.json"}, other
    # the colour PNGs, every one of them, differ by their encoding only
    colour = {p for p in b.rglob("*.png") if _pixels(p).ndim == 3}
    assert len(colour) >= 3 * (5 if fmt == "middlebury" else 2)  # images (and previews)
    assert {p.relative_to(b).as_posix() for p in colour} == encoded
    for path in colour:  # stored: larger than the deflated file, whose pixels it holds
        twin = a / path.relative_to(b)
        assert path.stat().st_size > twin.stat().st_size
        np.testing.assert_array_equal(_pixels(path), _pixels(twin))
    # grey PNGs (masks, KITTI's disparities) keep their bytes
    for path in b.rglob("*.png"):
        if path not in colour:
            assert path.read_bytes() == (a / path.relative_to(b)).read_bytes(), path
    # and the stored encoding is deterministic: a second run gives the same bytes
    c = tmp_path / "again"
    run_dataset(loads_config(_with("stored")), out=c, fmt=fmt, progress=False)
    assert not compare_datasets(b, c)


@pytest.mark.parametrize("fmt", ["crestereo", "fsd"])
def test_a_layout_of_jpeg_images_refuses_an_image_deflate(fmt, tmp_path):
    with pytest.raises(ParameterError, match=r"image_deflate = 'stored' has no PNG image to "
                                             r"encode in the .* layout, which stores its images "
                                             r"as JPEG; drop image_deflate"):
        run_dataset(loads_config(_with("stored")), out=tmp_path / "ds", fmt=fmt, progress=False)
    assert not (tmp_path / "ds").exists()  # refused before any work
