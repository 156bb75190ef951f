"""The bytes of one sample of every shipped dataset configuration, pinned by SHA-256.

A sample's bytes cover the whole chain: parameter sampling, the scene generator, rendering,
every photometric model (``flying`` uses all of them), the statistics in ``sample.json`` and
the writers. ``scene.json`` is hashed without its ``stereoforge_version`` field. PNG bytes depend
on the deflate libraries (libdeflate for grey images, ISA-L for colour: dependencies, see
``matcher.io.png``), so the pins hold for the project's environment.

Regenerate after an intended change of the bytes (and say why in the commit)::

    .venv/bin/python tests/synth/test_golden_samples.py
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path

import pytest

from synth.dataset.config.parse import list_examples, load_config
from synth.dataset.run import produce_sample

GOLDEN = Path(__file__).with_name("golden_samples.json")
# config -> the pinned sample: planes 0 (noise, gain, bias), texture-sweep 0 (boxes, 3 occluders,
# the edge-density search), flying 4 (every photometric model: blur, gamma, gain, bias, noise, JPEG),
# imperfect-rig 0 (distortion, rotation, offsets: the real cameras and flow0.flo),
# middlebury-like 0 (photograph textures, fences and grids, textureless walls), floating 0 (the
# room, every object family, deformations), dense 0 (up to 200 objects of every family),
# outdoor 0 (terrain, trees, bushes, rocks), mix 0 and 1 are two of its parts
CONFIGS = {"planes": 0, "texture-sweep": 0, "flying": 4, "imperfect-rig": 0, "middlebury-like": 0,
           "floating": 0, "dense": 0, "outdoor": 0, "mix": 0}


def _digest(path: Path) -> str:
    data = path.read_bytes()
    if path.name == "scene.json":
        record = json.loads(data)
        record.pop("stereoforge_version")
        data = json.dumps(record, sort_keys=True).encode()
    return hashlib.sha256(data).hexdigest()


def sample_hashes(config: str, index: int, renderer) -> dict[str, str]:
    cfg = load_config(config)
    with tempfile.TemporaryDirectory() as tmp:
        produce_sample(cfg, index, renderer, Path(tmp), "middlebury")
        return {p.name: _digest(p) for p in sorted(Path(tmp).iterdir())}


def test_every_shipped_dataset_config_is_pinned():
    shipped = {name for name in list_examples() if not name.startswith("study")}
    assert set(CONFIGS) == shipped
    assert set(json.loads(GOLDEN.read_text())) == set(CONFIGS)


@pytest.mark.gl
@pytest.mark.parametrize("config", sorted(CONFIGS))
def test_golden_sample_bytes(config, renderer):
    want = json.loads(GOLDEN.read_text())[config]
    assert want["index"] == CONFIGS[config]
    got = sample_hashes(config, want["index"], renderer)
    assert got == want["sha256"], sorted(k for k in got if got[k] != want["sha256"].get(k))


def _regenerate() -> None:
    from synth.render.renderer import Renderer

    with Renderer(64, 48) as renderer:
        table = {name: {"index": i, "sha256": sample_hashes(name, i, renderer)}
                 for name, i in sorted(CONFIGS.items())}
    GOLDEN.write_text(json.dumps(table, indent=2, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")


if __name__ == "__main__":
    sys.exit(_regenerate())
