"""Dependency contract: scenes (and matcher) never pull in synth, pyrender or OpenGL."""

from __future__ import annotations

import subprocess
import sys

import scenes


def test_scenes_and_matcher_do_not_import_gl() -> None:
    code = ("import scenes, matcher, sys; "
            "bad = sorted(m for m in sys.modules "
            "if m.split('.')[0] in ('synth', 'pyrender', 'OpenGL')); "
            "assert not bad, bad")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr


def test_public_api_is_exported() -> None:
    required = {"SceneSpec", "ObjectSpec", "TextureSpec", "Pose", "LightSpec", "load_scene",
                "dump_scene", "build_mesh", "build_meshes", "plane_equation", "make_texture",
                "get_preset", "list_presets", "PRESETS"}
    assert required <= set(scenes.__all__)
    assert all(hasattr(scenes, name) for name in scenes.__all__)
