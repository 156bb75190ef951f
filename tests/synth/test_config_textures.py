"""Per-object texture distributions of dataset configurations (the ``object_*`` keys)."""

from __future__ import annotations

import pytest

from stereoforge.errors import ConfigError
from synth.dataset.config.parse import loads_config
from synth.dataset.config.sampling import draw_sample

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


def test_mesh_occluders_are_centred_and_scaled(tmp_path) -> None:
    import numpy as np
    import trimesh

    import scenes

    path = tmp_path / "off.ply"
    trimesh.creation.icosphere(1, radius=3.0).apply_translation([10.0, 0, 0]).export(path)
    cfg = loads_config(f"[rig]\nwidth = 64\nheight = 48\n[scene]\noccluders = 2\n"
                       f"occluder_kind = 'mesh'\noccluder_mesh = '{path}'\n"
                       "occluder_depth = 1.5\noccluder_size = 0.2\n")
    occluders = [o for o in draw_sample(cfg, 0).scene.objects if o.kind == "mesh"]
    assert len(occluders) == 2
    side = 0.2 * cfg.rig.width * 1.5 / cfg.rig.fx
    for obj in occluders:
        mesh = scenes.build_mesh(obj)
        lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
        assert mesh.metadata["texture_source"] == "generated"
        assert float(np.linalg.norm(hi - lo)) <= side * 1.0001  # rotated box fits the diagonal
        centre = obj.pose.matrix() @ np.array([10.0 * obj.size[0], 0, 0, 1])
        assert centre[2] == pytest.approx(1.5)


@pytest.mark.parametrize("text, pattern", [
    ("[scene]\noccluders = 1\noccluder_kind = 'mesh'\n",
     r"scene\.occluder_kind: expected occluder_mesh beside a 'mesh' choice"),
    ("[scene]\noccluder_kind = 'mesh'\noccluder_mesh = 'nowhere/x.obj'\n",
     r"<string>:3: scene\.occluder_mesh: expected a mesh file trimesh loads, or a folder of "
     r"them, got 'nowhere/x\.obj'; mesh file 'nowhere/x\.obj' does not exist"),
])
def test_bad_mesh_occluders_name_the_problem(text: str, pattern: str) -> None:
    with pytest.raises(ConfigError, match=pattern):
        loads_config(text)
