"""Per-object texture distributions of dataset configurations (the ``object_*`` keys)."""

from __future__ import annotations

import pytest

from stereoforge.errors import ConfigError
from synth.dataset.config import loads_config
from synth.dataset.sampling import draw_sample

_MIX = """
[rig]
width = 64
height = 48
[scene]
base = "flying"
object_texture = {choice = ["image", "image", "noise", "constant"]}
object_image = {choice = ["skimage:brick", "skimage:grass"]}
object_frequency_px = {loguniform = [0.05, 0.2]}
object_contrast = {uniform = [0.5, 1.0]}
"""


def test_every_object_draws_its_own_texture() -> None:
    cfg = loads_config(_MIX)
    kinds, images = set(), set()
    for i in range(6):
        draw = draw_sample(cfg, i)
        assert draw == draw_sample(cfg, i)  # seeded
        for obj in draw.scene.objects:
            t = obj.texture
            kinds.add(t.kind)
            assert (t.kind == "image") == bool(t.image)
            images.add(t.image)
            f_px = t.frequency * obj.pose.translation[2] / cfg.rig.fx
            assert 0.05 - 1e-12 <= f_px <= 0.2 + 1e-12
            assert 0.5 <= t.contrast <= 1.0
        seeds = [o.texture.seed for o in draw.scene.objects]
        assert len(set(seeds)) == len(seeds)
    assert kinds == {"image", "noise", "constant"}
    assert images == {"", "skimage:brick", "skimage:grass"}


def test_without_the_keys_samples_are_unchanged() -> None:
    plain = loads_config("[scene]\nbase = 'flying'\n")
    assert "object_texture" not in plain.scene
    assert draw_sample(plain, 2).scene == draw_sample(loads_config("[scene]\nbase = 'flying'\n"),
                                                      2).scene


@pytest.mark.parametrize("text, pattern", [
    ("[scene]\nobject_contrast = 0.5\n", r"scene\.object_contrast: expected object_texture"),
    ("[scene]\nobject_texture = 'image'\n", r"expected object_image beside an 'image' choice"),
    ("[scene]\nobject_texture = 'image'\nobject_image = {choice = ['skimage:bricks']}\n",
     r"<string>:3: scene\.object_image: expected skimage:<name>.*got 'skimage:bricks'"),
    ("[scene]\nobject_texture = 'noise'\nedge_density = 0.1\n",
     r"edge_density or object_texture, not both"),
    ("[scene]\nobject_texture = 'marble'\n", r"scene\.object_texture: expected one of"),
])
def test_bad_per_object_keys_name_the_problem(text: str, pattern: str) -> None:
    with pytest.raises(ConfigError, match=pattern):
        loads_config(text)
