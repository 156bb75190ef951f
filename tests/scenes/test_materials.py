"""Materials and lamps: defaults leave scene files as they were, exact round trips, bad values."""

from __future__ import annotations

import dataclasses

import pytest

import scenes
from scenes import LampSpec, MaterialSpec, SceneSpec, dumps_json, loads_json, loads_toml
from scenes.materials import MAX_LAMPS
from stereoforge.errors import StereoforgeError


def test_matte_scenes_write_neither_material_nor_lamps() -> None:
    for name in scenes.PRESETS:
        spec = scenes.get_preset(name)
        assert not spec.is_lit()
        text = dumps_json(spec)
        assert '"material"' not in text and '"lamps"' not in text


def test_materials_and_lamps_round_trip_exactly() -> None:
    base = scenes.get_preset("boxes")
    shiny = dataclasses.replace(base.objects[0], material=MaterialSpec(0.7, 128.0))
    rough = dataclasses.replace(base.objects[1], material=MaterialSpec(0.2, model="ggx",
                                                                       roughness=0.4))
    spec = dataclasses.replace(base, objects=(shiny, rough, *base.objects[2:]), lamps=(
        LampSpec("point", position=(0.5, -1.0, 0.2), intensity=3.0),
        LampSpec("directional", direction=(-0.2, 0.4, 1.0), shadows=False)))
    assert spec.is_lit() and spec.has_specular()
    assert loads_json(dumps_json(spec)) == spec
    assert loads_toml(scenes.dumps_toml(spec)) == spec
    lamp_only = dataclasses.replace(base, lamps=spec.lamps)
    assert lamp_only.is_lit() and not lamp_only.has_specular()


@pytest.mark.parametrize(("change", "match"), [
    ({"material": {"specular": -0.1}}, r"objects\[0\].material: MaterialSpec.specular: expected a finite number in \[0.0, 16.0\]"),
    ({"material": {"shininess": 0.5}}, r"MaterialSpec.shininess"),
    ({"material": {"gloss": 1.0}}, r"gloss"),
    ({"material": {"model": "phong"}}, r"MaterialSpec.model"),
    ({"material": {"roughness": 0.0}}, r"MaterialSpec.roughness: expected a finite number in \[0.02, 1.0\]"),
])
def test_bad_materials_are_refused_with_one_error(change: dict, match: str) -> None:
    data = scenes.scene_to_dict(scenes.get_preset("fronto_plane"))
    data["objects"][0].update(change)
    with pytest.raises(StereoforgeError, match=match):
        scenes.scene_from_dict(data)


@pytest.mark.parametrize(("lamp", "match"), [
    ({"kind": "spot"}, r"LampSpec.kind"),
    ({"direction": [0, 0, 0]}, r"LampSpec.direction: expected a non-zero 3-vector"),
    ({"intensity": -1}, r"LampSpec.intensity"),
    ({"shadows": 1}, r"LampSpec.shadows"),
    ({"colour": [1, 1, 1]}, r"colour"),
])
def test_bad_lamps_are_refused_with_one_error(lamp: dict, match: str) -> None:
    data = scenes.scene_to_dict(scenes.get_preset("fronto_plane"))
    data["lamps"] = [lamp]
    with pytest.raises(StereoforgeError, match=match) as info:
        scenes.scene_from_dict(data)
    assert "lamps[0]" in str(info.value)


def test_too_many_lamps_are_refused() -> None:
    spec = scenes.get_preset("fronto_plane")
    with pytest.raises(StereoforgeError, match=f"at most {MAX_LAMPS} lamps"):
        dataclasses.replace(spec, lamps=(LampSpec(),) * (MAX_LAMPS + 1))
    with pytest.raises(StereoforgeError, match="scene.lamps: expected an array of tables"):
        scenes.scene_from_dict({**scenes.scene_to_dict(spec), "lamps": {"kind": "point"}})
