"""Scene specifications: hand-picked round trips, defaults and validation errors."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from scenes.spec import LightSpec, ObjectSpec, Pose, SceneSpec, TextureSpec
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


def _scene() -> SceneSpec:
    awkward = 0.1 + 0.2  # 0.30000000000000004: must survive exactly
    objects = (
        ObjectSpec("plane", Pose((0.05, 0.0, 2.0), (10.0, 30.0, 0.0)), (3.0, awkward),
                   TextureSpec(kind="checker", frequency=1e-3, seed=2**63 - 1), name="wall"),
        ObjectSpec("moebius", Pose((-1.5e-300, 5e-324, 999999.9999999999)), (1.0, 1.9999),
                   TextureSpec(kind="stripes", angle=-0.0, color=(0.25, 1.0, 0.0)),
                   name="strip \"quoted\" é\n", segments=4096, seed=7),
        ObjectSpec("terrain", Pose(), (30.0, 20.0, 0.0), TextureSpec(kind="constant")),
    )
    return SceneSpec("hand", objects, light=LightSpec((0.0, 0.0, -1e-9), 0.0, 2.5),
                     background=(1.0, 0.5, awkward / 3), seed=12345, description="a\tb")


@pytest.mark.parametrize("fmt", ["json", "toml"])
def test_round_trip_hand_example(fmt: str) -> None:
    spec = _scene()
    dumps, loads = (dumps_json, loads_json) if fmt == "json" else (dumps_toml, loads_toml)
    back = loads(dumps(spec))
    assert back == spec
    assert isinstance(back.objects, tuple) and isinstance(back.objects[0].size, tuple)
    assert isinstance(back.objects[1].texture.color, tuple)
    assert back.objects[0].size[1] == 0.1 + 0.2
    assert back.objects[1].pose.translation[1] == 5e-324


@pytest.mark.parametrize("suffix", [".json", ".toml", ".TOML"])
def test_dump_load_files(tmp_path, suffix: str) -> None:
    spec = _scene()
    path = dump_scene(spec, tmp_path / f"scene{suffix}")
    assert load_scene(path) == spec
    text = path.read_text(encoding="utf-8")
    data = json.loads(text) if suffix == ".json" else tomllib.loads(text)
    assert data["version"] == 1 and data["objects"][0]["kind"] == "plane"


@pytest.mark.parametrize("suffix", [".json", ".toml"])
def test_a_utf8_byte_order_mark_is_dropped(tmp_path, suffix: str) -> None:
    spec = _scene()
    path = dump_scene(spec, tmp_path / f"scene{suffix}")
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())  # as some Windows editors save it
    assert load_scene(path) == spec


def test_unknown_suffix_is_rejected(tmp_path) -> None:
    with pytest.raises(ValueError, match=r"\.json.*\.toml.*'\.yaml'"):
        dump_scene(_scene(), tmp_path / "scene.yaml")
    with pytest.raises(ValueError, match="suffix"):
        load_scene(tmp_path / "scene.txt")


def test_minimal_dict_takes_defaults() -> None:
    spec = scene_from_dict({"name": "s", "objects": [{"kind": "sphere", "size": [1]}]})
    assert spec.objects[0].pose == Pose()
    assert spec.objects[0].texture == TextureSpec()
    assert spec.light == LightSpec() and spec.background == (0.0, 0.0, 0.0)
    assert isinstance(spec.objects[0].size[0], float)  # TOML/JSON ints become floats


def test_to_dict_is_plain() -> None:
    data = scene_to_dict(_scene())
    assert json.loads(json.dumps(data)) == data  # only lists, dicts, str, numbers
    assert isinstance(data["objects"][0]["pose"]["translation"], list)


def test_pose_matrix_convention() -> None:
    pose = Pose(translation=(1.0, 2.0, 3.0), rotation_deg=(0.0, 90.0, 0.0))
    m = pose.matrix()
    assert m.shape == (4, 4) and m.dtype == np.float64
    np.testing.assert_allclose(m[3], [0, 0, 0, 1])
    # Ry(+90) turns z toward x
    np.testing.assert_allclose(m[:3, :3] @ [0, 0, 1], [1, 0, 0], atol=1e-15)
    # extrinsic X then Z: x-rotation by 90 sends y to z; z-rotation by 90 then sends z to z
    r = Pose(rotation_deg=(90.0, 0.0, 90.0)).rotation()
    np.testing.assert_allclose(r @ [0, 1, 0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(r @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(r) == pytest.approx(1.0)


def _obj_dict(**changes) -> dict:
    data = {"kind": "box", "size": [1.0, 1.0, 1.0], "pose": {}, "texture": {}}
    data.update(changes)
    return data


@pytest.mark.parametrize(("data", "pattern"), [
    ({"name": "s", "objects": [_obj_dict()], "colour": 1},
     r"unknown key 'colour' in scene; valid keys: \['name', 'objects'"),
    ({"name": "s", "objects": [_obj_dict(), _obj_dict(texure={})]},
     r"unknown key 'texure' in objects\[1\]; valid keys: .*'texture'"),
    ({"name": "s", "objects": [_obj_dict(pose={"rotation": [0, 0, 0]})]},
     r"unknown key 'rotation' in objects\[0\]\.pose; "
     r"valid keys: \['translation', 'rotation_deg'\]"),
    ({"name": "s", "objects": [_obj_dict(texture={"freq": 2})]},
     r"unknown key 'freq' in objects\[0\]\.texture"),
    ({"name": "s", "objects": [_obj_dict()], "light": {"colour": 1}},
     r"unknown key 'colour' in scene\.light"),
    ({"name": "s", "objects": [_obj_dict(kind="cube")]},
     r"objects\[0\]: ObjectSpec\.kind: expected one of \['plane', 'box', 'sphere', 'cylinder', "
     r"'moebius', 'terrain', 'fence', 'grid', 'mesh', 'superquadric', 'rock', 'torus', "
     r"'knot', 'revolution', 'extrusion', 'polyhedron', 'tree', 'bush', 'wire', "
     r"'furniture'\], "
     r"got 'cube'"),
    ({"name": "s", "objects": [_obj_dict(texture={"kind": "perlin"})]},
     r"objects\[0\]\.texture.*\['noise', 'checker', 'stripes', 'constant', 'image'\], got 'perlin'"),
    ({"name": "s", "objects": [{"pose": {}, "size": [1.0]}]},
     r"objects\[0\] is missing the required key\(s\) \['kind'\]"),
    ({"objects": [_obj_dict()]}, r"scene is missing the required key\(s\) \['name'\]"),
    ({"name": "s", "objects": []}, "at least one ObjectSpec"),
    ({"name": "s", "objects": [_obj_dict()], "version": 2}, "unsupported scene format version 2"),
])
def test_dict_errors_name_the_problem(data: dict, pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        scene_from_dict(data)


@pytest.mark.parametrize(("build", "pattern"), [
    (lambda: TextureSpec(contrast=1.5),
     r"^TextureSpec\.contrast: expected a finite number in \[0\.0, 1\.0\], got 1\.5$"),
    (lambda: TextureSpec(contrast=-0.1), r"contrast: expected .* in \[0\.0, 1\.0\], got -0\.1"),
    (lambda: TextureSpec(frequency=0.0), r"frequency: expected a finite number > 0\.0, got 0\.0"),
    (lambda: TextureSpec(mean=float("nan")), r"mean: expected a finite number in \[0\.0, 1\.0\], "
                                             r"got nan"),
    (lambda: TextureSpec(color=(1.0, 1.0)), r"color: expected a sequence of 3 numbers, got 2 "
                                            r"entries \(1\.0, 1\.0\)"),
    (lambda: TextureSpec(seed=-1), r"seed: expected an integer in \[0, 9223372036854775808\), "
                                   r"got -1"),
    (lambda: Pose(translation=(0.0, float("inf"), 0.0)),
     r"translation\[1\]: expected a finite number in \[-1000000\.0, 1000000\.0\], got inf"),
    (lambda: Pose(translation=(0.0, 0.0, 2e6)),
     r"translation\[2\]: expected a finite number in \[-1000000\.0, 1000000\.0\], got 2000000\.0"),
    (lambda: ObjectSpec("box", Pose(), (1.0, 0.0, 1.0)),
     r"ObjectSpec\.size\[1\] \(sy of a box\): expected a finite number in \(0\.0, 1000000\.0\], "
     r"got 0\.0; sizes are metres, at most MAX_EXTENT = 1e\+06"),
    (lambda: ObjectSpec("plane", Pose(), (1e300, 1.0)),
     r"ObjectSpec\.size\[0\] \(width of a plane\): expected a finite number in \(0\.0, "
     r"1000000\.0\], got 1e\+300"),
    (lambda: ObjectSpec("sphere", Pose(), (1.0, 2.0)),
     r"sphere \('radius',\): expected a sequence of 1 number, got 2 entries"),
    (lambda: ObjectSpec("terrain", Pose(), (1.0, 1.0, -0.1)),
     r"size\[2\] \(amplitude of a terrain\): expected a finite number in \[0\.0, 1000000\.0\], got -0\.1"),
    (lambda: ObjectSpec("moebius", Pose(), (1.0, 2.0)),
     r"expected width < 2 \* radius, got \(1\.0, 2\.0\); narrow the strip"),
    (lambda: ObjectSpec("sphere", Pose(), (1.0,), segments=2),
     r"segments: expected an integer in \[3, 4096\], got 2"),
    (lambda: LightSpec(direction=(0.0, 0.0, 0.0)),
     r"direction: expected a finite non-zero length, got \(0\.0, 0\.0, 0\.0\); give a direction"),
    (lambda: LightSpec(intensity=-1.0), r"intensity: expected a finite number >= 0\.0, got -1\.0"),
    (lambda: SceneSpec("s", (), ), r"at least one ObjectSpec"),
    (lambda: SceneSpec("s", (ObjectSpec("sphere", Pose(), (1.0,)),), background=(2.0, 0, 0)),
     r"background\[0\]: expected a finite number in \[0\.0, 1\.0\], got 2\.0"),
])
def test_value_errors(build, pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        build()


@pytest.mark.parametrize(("build", "pattern"), [
    (lambda: TextureSpec(frequency="4"),
     r"frequency: expected a finite number > 0\.0, got str '4'"),
    (lambda: TextureSpec(seed=1.0), r"seed: expected an integer in \[0, .*\), got float 1\.0"),
    (lambda: TextureSpec(contrast=True), r"contrast: expected a finite number .*, got bool True"),
    (lambda: ObjectSpec("box", (0, 0, 0), (1.0, 1.0, 1.0)),
     r"ObjectSpec\.pose: expected a Pose, got tuple \(0, 0, 0\)"),
    (lambda: ObjectSpec("box", Pose(), 1.0), r"size .*: expected a sequence of 3 numbers, "
                                             r"got float 1\.0"),
    (lambda: SceneSpec("s", ("plane",)), r"objects\[0\]: expected an ObjectSpec, got str 'plane'"),
])
def test_type_errors(build, pattern: str) -> None:
    with pytest.raises(TypeError, match=pattern):
        build()


def test_specs_are_frozen_and_hashable() -> None:
    spec = _scene()
    with pytest.raises(AttributeError):
        spec.name = "other"  # type: ignore[misc]
    assert hash(spec) == hash(loads_json(dumps_json(spec)))


def test_numpy_scalars_are_coerced() -> None:
    tex = TextureSpec(frequency=np.float32(2.5), seed=np.int64(3))
    assert type(tex.frequency) is float and type(tex.seed) is int
    assert loads_toml(dumps_toml(SceneSpec("s", (ObjectSpec("sphere", Pose(), (1.0,), tex),)))
                      ).objects[0].texture == tex


@pytest.mark.parametrize("direction", [(1e-200, 0.0, 0.0), (1e200, 1e200, 0.0), (0.3, 0.5, 1.0)])
def test_light_unit_direction_survives_tiny_and_huge_lengths(direction):
    # the squared norm of these under/overflows; the direction itself is fine
    u = LightSpec(direction=direction).unit_direction()
    assert np.isfinite(u).all() and abs(float(np.linalg.norm(u)) - 1.0) < 1e-12


def test_scene_errors_are_stereoforge_errors_told_where() -> None:
    from stereoforge.errors import ParameterError, ParameterTypeError, SceneError

    with pytest.raises(SceneError, match=r"did you mean 'texture'\?"):
        scene_from_dict({"name": "s", "objects": [_obj_dict(texure={})]})
    with pytest.raises(ParameterError, match=r"^objects\[0\]: ObjectSpec\.size\[0\]"):
        scene_from_dict({"name": "s", "objects": [_obj_dict(size=[-1.0, 1.0, 1.0])]})
    with pytest.raises(ParameterTypeError, match=r"^objects\[0\]\.pose: Pose\.translation: "
                                                 r"expected a sequence of 3 numbers, got str"):
        scene_from_dict({"name": "s", "objects": [_obj_dict(pose={"translation": "0 0 1"})]})
    with pytest.raises(TypeError, match=r"^scene\.objects: expected an array of tables"):
        scene_from_dict({"name": "s", "objects": 3})
    with pytest.raises(SceneError, match="suffix"):
        load_scene("scene.yaml")
