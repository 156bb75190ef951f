"""Procedural scenes for stereoforge: specifications, meshes, textures and presets.

Pure numpy + trimesh (no OpenGL). A scene is data (:class:`SceneSpec`) in the left camera's frame
(OpenCV orientation, metres); :func:`build_meshes` turns it into textured world-space meshes.
"""

from scenes.materials import LAMP_KINDS, LampSpec, MaterialSpec
from scenes.presets import PRESETS, Preset, get_preset, list_presets
from scenes.primitives import build_mesh, build_meshes, plane_equation
from scenes.spec import FAMILY_KINDS, LightSpec, ObjectSpec, Pose, SceneSpec, TextureSpec
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
from scenes.skyspec import SkySpec
from scenes.textures import make_texture

__all__ = [
    "SceneSpec",
    "ObjectSpec",
    "TextureSpec",
    "Pose",
    "LightSpec",
    "SkySpec",
    "MaterialSpec",
    "LampSpec",
    "LAMP_KINDS",
    "FAMILY_KINDS",
    "load_scene",
    "dump_scene",
    "loads_json",
    "dumps_json",
    "loads_toml",
    "dumps_toml",
    "scene_to_dict",
    "scene_from_dict",
    "build_mesh",
    "build_meshes",
    "plane_equation",
    "make_texture",
    "get_preset",
    "list_presets",
    "PRESETS",
    "Preset",
]
