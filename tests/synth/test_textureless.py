"""Textureless area: per-object pixel coverage (measured) and the target search."""

from __future__ import annotations

import numpy as np
import pytest
import scenes
from scenes import ObjectSpec, Pose, SceneSpec, TextureSpec

from synth.dataset.config.parse import loads_config
from synth.dataset.run import produce_sample
from synth.camera.rig import StereoRig
from synth.appearance.textureless import match_textureless, object_coverage

pytestmark = pytest.mark.gl

RIG = StereoRig(width=64, height=48, fx=60.0, fy=60.0, cx=31.5, cy=23.5, baseline=0.1)


def _two_planes() -> SceneSpec:
    wall = ObjectSpec("plane", Pose(translation=(0.05, 0.0, 4.0)),
                      scenes.presets.frame_cover_size(4.0), TextureSpec(seed=1), name="wall")
    # a 1.0 x 0.6 m card at 2 m centred at (0.1, 0.05): x in [-0.4, 0.6] -> u in (19.5, 49.5)
    # shifted by 0.3 px; y in [-0.25, 0.35] -> v in (16.0, 34.0) shifted
    card = ObjectSpec("plane", Pose(translation=(0.1 + 0.01, 0.05 + 0.011, 2.0)), (1.0, 0.6),
                      TextureSpec(seed=2), name="card")
    return SceneSpec("two", (card, wall))


def test_coverage_counts_the_pixel_centres_each_object_owns(renderer) -> None:
    scene = _two_planes()
    cov = object_coverage(scene, lambda s: renderer.render_view(s, RIG, eye="left").color)
    card = scene.objects[0]
    (x, y, z), (w, h) = card.pose.translation, card.size
    u = RIG.cx + RIG.fx * np.array([x - w / 2, x + w / 2]) / z
    v = RIG.cy + RIG.fy * np.array([y - h / 2, y + h / 2]) / z
    cols = np.count_nonzero((np.arange(RIG.width) > u[0]) & (np.arange(RIG.width) < u[1]))
    rows = np.count_nonzero((np.arange(RIG.height) > v[0]) & (np.arange(RIG.height) < v[1]))
    inside, perimeter = rows * cols, 2 * (rows + cols)
    assert inside - perimeter <= cov[0] <= inside
    outside = RIG.width * RIG.height - inside
    assert outside - perimeter <= cov[1] <= outside


def test_match_textureless_reports_what_it_made(renderer) -> None:
    scene = scenes.get_preset("flying", seed=5)
    render = lambda s: renderer.render_view(s, RIG, eye="left").color  # noqa: E731
    cov = object_coverage(scene, render)
    n = RIG.width * RIG.height
    assert cov.sum() >= 0.9 * n  # every pixel but blended silhouettes belongs to one object
    for target in (0.0, 0.3, 1.0):
        out, fraction = match_textureless(scene, target, cov, n, np.random.default_rng(0))
        flat = [o.texture.kind == "constant" for o in out.objects]
        assert fraction == pytest.approx(cov[flat].sum() / n)
        # the retextured scene has the same geometry: the same coverage
        assert (object_coverage(out, render) == cov).all()
        if target == 0.0:
            assert not any(flat)
    # flying has no constant object: the greedy search starts at 0 and only steps closer
    _, fraction = match_textureless(scene, 0.3, cov, n, np.random.default_rng(0))
    assert 0.0 < fraction and abs(fraction - 0.3) < 0.3


def test_dataset_stat_is_written_only_when_asked(renderer, tmp_path) -> None:
    base = "[rig]\nwidth = 64\nheight = 48\n[scene]\nbase = 'flying'\n"
    plain = produce_sample(loads_config(base), 0, renderer, tmp_path / "a", "middlebury")
    assert "textureless_fraction" not in plain["stats"]
    asked = produce_sample(loads_config(base + "textureless_area = 0.4\n"), 0, renderer,
                           tmp_path / "b", "middlebury")
    assert 0.0 < asked["stats"]["textureless_fraction"] <= 1.0
