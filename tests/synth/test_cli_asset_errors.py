"""Bad photographs and mesh files named by a scene: one ``Error:`` line through the CLI, exit 2,
no output left behind."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from synth.cli import main

pytestmark = pytest.mark.gl


def _scene(texture: dict | None = None, **obj) -> str:
    base = {"kind": "plane", "pose": {"translation": [0.05, 0, 2]}, "size": [3, 2],
            "texture": texture or {}}
    base.update(obj)
    return json.dumps({"name": "x", "objects": [base]})


CASES = [
    ("missing image", _scene({"kind": "image", "image": "nope/missing.png"}),
     ["photograph", "nope/missing.png", "does not exist", "check the path"]),
    ("not an image", _scene({"kind": "image", "image": "fake.png"}),
     ["fake.png", "not an image Pillow can read"]),
    ("empty folder", _scene({"kind": "image", "image": "empty"}),
     ["folder", "holds no image file"]),
    ("unknown skimage name", _scene({"kind": "image", "image": "skimage:bricks"}),
     ["skimage:<name>", "'bricks'", "did you mean 'brick'"]),
    ("mesh trimesh cannot load", _scene(kind="mesh", size=[1.0], path="broken.ply"),
     ["mesh file", "broken.ply", "cannot be loaded by trimesh"]),
    ("missing mesh", _scene(kind="mesh", size=[1.0], path="gone.obj"),
     ["mesh file", "gone.obj", "does not exist"]),
]


@pytest.mark.parametrize(("name", "scene", "words"), CASES, ids=[c[0] for c in CASES])
def test_bad_asset_is_one_error_line(tmp_path: Path, name: str, scene: str, words) -> None:
    (tmp_path / "fake.png").write_text("this is text")
    (tmp_path / "empty").mkdir()
    (tmp_path / "broken.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\n"
                                          b"element vertex 9\nend_header\n\x00")
    (tmp_path / "scene.json").write_text(scene)
    old = Path.cwd()
    os.chdir(tmp_path)
    try:
        result = CliRunner().invoke(main, ["render", "scene.json", "--out", "out",
                                           "--width", "32", "--height", "24"])
    finally:
        os.chdir(old)
    output = result.output
    assert "Traceback" not in output, output
    errors = [line for line in output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1, output
    assert result.exit_code == 2, output
    for word in words:
        assert word.lower() in errors[0].lower(), (word, errors[0])
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
