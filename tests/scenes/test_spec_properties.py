"""Property tests: every valid scene round-trips exactly through JSON, TOML and files."""

from __future__ import annotations

import tempfile
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from scenes.spec import SceneSpec
from scenes.serialize import (
    dump_scene,
    dumps_json,
    dumps_toml,
    load_scene,
    loads_json,
    loads_toml,
    scene_from_dict,
    scene_to_dict,
)
from scenes.strategies import scene_specs


@given(scene_specs())
def test_json_round_trip_is_exact(spec: SceneSpec) -> None:
    assert loads_json(dumps_json(spec)) == spec


@given(scene_specs())
def test_toml_round_trip_is_exact(spec: SceneSpec) -> None:
    back = loads_toml(dumps_toml(spec))
    assert back == spec
    assert all(isinstance(o.size, tuple) and isinstance(o.pose.translation, tuple)
               for o in back.objects)


@given(scene_specs())
def test_dict_round_trip_is_exact(spec: SceneSpec) -> None:
    assert scene_from_dict(scene_to_dict(spec)) == spec


@given(scene_specs(max_objects=2), st.sampled_from([".json", ".toml"]))
def test_file_round_trip_is_exact(spec: SceneSpec, suffix: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = dump_scene(spec, Path(tmp) / f"scene{suffix}")
        assert load_scene(path) == spec
