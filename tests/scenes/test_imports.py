"""The scenes package exports its public API (the import contract is in tests/test_architecture.py)."""

from __future__ import annotations

import scenes


def test_public_api_is_exported() -> None:
    required = {"SceneSpec", "ObjectSpec", "TextureSpec", "Pose", "LightSpec", "load_scene",
                "dump_scene", "build_mesh", "build_meshes", "plane_equation", "make_texture",
                "get_preset", "list_presets", "PRESETS"}
    assert required <= set(scenes.__all__)
    assert all(hasattr(scenes, name) for name in scenes.__all__)
