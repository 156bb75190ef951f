"""Per-sample seeds, parameter draws and scenes (synth.dataset.config.sampling)."""

from __future__ import annotations

import numpy as np
import pytest

from synth.dataset.config.parse import loads_config
from synth.dataset.config.sampling import draw_sample, effective_frequency_px, sample_seed, stream

CFG = loads_config("""
seed = 4
[scene]
base = {choice = ["fronto_plane", "boxes"]}
texture = "checker"
frequency_px = {uniform = [0.05, 0.1]}
occluders = {uniform = [1, 3]}
occluder_size = 0.2
occluder_depth = 1.2
[photometric]
noise_sigma = {uniform = [1.0, 2.0]}
""")


def test_sample_seed_follows_seedsequence_spawn_key():
    expected = np.random.SeedSequence(4, spawn_key=(9,)).generate_state(1, np.uint64)[0] >> 1
    assert sample_seed(4, 9) == int(expected)
    seeds = {sample_seed(4, i) for i in range(100)}
    assert len(seeds) == 100 and all(0 <= s < 2**63 for s in seeds)
    with pytest.raises(ValueError, match="index must be an int >= 0"):
        sample_seed(4, -1)


def test_streams_are_independent_and_reproducible():
    a = stream(123, 0).random(4)
    np.testing.assert_array_equal(a, stream(123, 0).random(4))
    assert not np.array_equal(a, stream(123, 1).random(4))


def test_a_sample_does_not_depend_on_the_others():
    later = draw_sample(CFG, 5)
    for i in range(5):
        draw_sample(CFG, i)
    assert draw_sample(CFG, 5) == later
    assert draw_sample(CFG, 6) != later


def test_drawn_scene_follows_the_parameters():
    d = draw_sample(CFG, 2)
    p = d.params
    assert 0.05 <= p["scene.frequency_px"] <= 0.1 and 1 <= p["scene.occluders"] <= 3
    assert d.photometric.noise_sigma == p["photometric.noise_sigma"]  # drawn value is applied
    sigmas = {draw_sample(CFG, i).photometric.noise_sigma for i in range(8)}
    assert len(sigmas) == 8 and all(1.0 <= s <= 2.0 for s in sigmas)  # uniform [1, 2]
    occluders = [o for o in d.scene.objects if o.name.startswith("occluder")]
    assert len(occluders) == p["scene.occluders"]
    rig = CFG.rig
    for o in occluders:
        x, y, z = o.pose.translation
        assert z == 1.2
        assert -0.5 <= rig.fx * x / z + rig.cx <= rig.width - 0.5  # centre in the image
        assert -0.5 <= rig.fy * y / z + rig.cy <= rig.height - 0.5
        assert o.size[0] == pytest.approx(0.2 * rig.width * z / rig.fx)
    for o in d.scene.objects:
        assert o.texture.kind == "checker"
        assert o.texture.frequency == pytest.approx(
            p["scene.frequency_px"] * rig.fx / o.pose.translation[2])
    assert effective_frequency_px(d.scene, fx=rig.fx) == pytest.approx(p["scene.frequency_px"])
