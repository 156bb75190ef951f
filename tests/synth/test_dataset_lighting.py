"""Datasets with specular materials, lamps and the im1E / im1L variants."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from matcher.io import read_image, read_pfm
from stereoforge.errors import ConfigError
from synth.dataset.config.parse import loads_config
from synth.dataset.run import render_from_manifest, run_dataset
from synth.dataset.config.sampling import draw_sample

BASE = """\
name = "lit"
seed = 5
count = 2
[rig]
width = 64
height = 48
[scene]
base = "boxes"
"""
LIT = BASE + """\
specular_fraction = 1.0
specular = {uniform = [0.4, 0.9]}
shininess = {loguniform = [16, 128]}
specular_model = {choice = ["blinn-phong", "ggx"]}
roughness = {uniform = [0.1, 0.5]}
lamps = {choice = [1, 2]}
lamp_intensity = 0.4
exposure_variant = 0.5
lighting_variant = 30
"""


def test_lit_keys_draw_materials_and_lamps_per_item() -> None:
    cfg = loads_config(LIT)
    draw = draw_sample(cfg, 0)
    assert draw == draw_sample(cfg, 0)
    objects = draw.scene.objects
    assert all(0.4 <= o.material.specular <= 0.9 and 16 <= o.material.shininess <= 128
               for o in objects)
    assert len({o.material.specular for o in objects}) == len(objects)  # drawn per object
    assert {o.material.model for o in objects} == {"blinn-phong", "ggx"}
    assert all(0.1 <= o.material.roughness <= 0.5 for o in objects)
    assert len(draw.scene.lamps) == draw.params["scene.lamps"] in (1, 2)
    assert draw.params["scene.specular_objects"] == len(objects)
    assert draw.exposure == 0.5
    light, lamps = draw.relight
    turned = np.degrees(np.arccos(np.clip(light.unit_direction()
                                          @ draw.scene.light.unit_direction(), -1, 1)))
    assert abs(turned - 30.0) < 1e-9 and len(lamps) == len(draw.scene.lamps)
    # the matte config draws the same geometry: the new keys use their own stream
    matte = draw_sample(loads_config(BASE), 0)
    assert [o.pose for o in matte.scene.objects] == [o.pose for o in objects]
    assert not matte.scene.is_lit() and matte.exposure is None and matte.relight is None


@pytest.mark.parametrize(("line", "needle"), [
    ("specular = -0.5", "scene.specular: expected a finite number in [0.0, 16.0], got -0.5"),
    ("lamps = 9", "scene.lamps: expected an integer in [0, 7]"),
    ("exposure_variant = 0", "scene.exposure_variant"),
    ("lamp_shadows = 2", "scene.lamp_shadows"),
])
def test_bad_lit_keys_are_one_config_error(line: str, needle: str) -> None:
    with pytest.raises(ConfigError) as info:
        loads_config(BASE + line + "\n")
    assert needle in str(info.value) and "<string>:9" in str(info.value)


def _sample(root: Path) -> Path:
    return root / "MiddEval3" / "trainingF" / "000000"


@pytest.mark.gl
def test_lit_dataset_writes_variants_and_masks_and_keeps_the_gt(tmp_path, renderer) -> None:
    lit, matte = tmp_path / "lit", tmp_path / "matte"
    for text, out in ((LIT, lit), (BASE, matte)):
        (tmp_path / f"{out.name}.toml").write_text(text)
        run_dataset(tmp_path / f"{out.name}.toml", out=out, workers=1, progress=False)
    for i in range(2):
        a, b = _sample(lit).with_name(f"{i:06d}"), _sample(matte).with_name(f"{i:06d}")
        assert not (b / "mask0spec.png").exists()
        assert (b / "im1E.png").read_bytes() == (b / "im1.png").read_bytes()
        for name in ("disp0GT.pfm", "disp1GT.pfm", "mask0nocc.png"):
            assert (a / name).read_bytes() == (b / name).read_bytes(), name
        im1, im1e = read_image(a / "im1.png"), read_image(a / "im1E.png")
        assert im1e.mean() < im1.mean() - 10  # half the light
        assert (a / "im1L.png").read_bytes() != (a / "im1.png").read_bytes()
        masks = [read_image(a / f"mask{k}spec.png") for k in (0, 1)]
        assert all(set(np.unique(m)) <= {0, 255} for m in masks)
        assert read_pfm(a / "disp0GT.pfm").shape == (48, 64)
    again = tmp_path / "again"
    render_from_manifest(lit, 1, out=again)
    for path in again.iterdir():  # variants and masks re-rendered alone: the same bytes
        assert path.read_bytes() == (_sample(lit).with_name("000001") / path.name).read_bytes(), \
            path.name
