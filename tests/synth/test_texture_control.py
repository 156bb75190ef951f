"""Texture frequency conversion, retexturing, edge density and the closed-loop search."""

from __future__ import annotations

import numpy as np
import pytest

import scenes
from synth.camera.rig import StereoRig
from synth.appearance.texture_control import (
    CANNY_SETTINGS,
    SEARCH_TOL,
    edge_density,
    frequency_per_metre,
    match_edge_density,
    retexture,
)

RIG = StereoRig.default(64, 48)


def test_frequency_per_metre_is_f_px_fx_over_z():
    assert frequency_per_metre(0.1, fx=600.0, depth=3.0) == pytest.approx(20.0)
    with pytest.raises(ValueError, match="depth must be a finite number > 0"):
        frequency_per_metre(0.1, fx=600.0, depth=0.0)


def test_retexture_uses_each_objects_centre_depth():
    base = scenes.get_preset("boxes", seed=1)
    s = retexture(base, fx=600.0, frequency_px=0.05, contrast=0.3, kind="checker")
    for old, new in zip(base.objects, s.objects):
        z = old.pose.translation[2]
        assert new.texture.frequency == pytest.approx(0.05 * 600.0 / z)
        assert (new.texture.contrast, new.texture.kind) == (0.3, "checker")
        assert (new.texture.seed, new.texture.mean) == (old.texture.seed, old.texture.mean)
        assert new.pose == old.pose
    assert retexture(base, fx=600.0) == base


def test_edge_density_uses_the_project_canny():
    assert CANNY_SETTINGS == {"sigma": 1.0, "low": 0.1, "high": 0.2}
    img = np.zeros((32, 32), np.uint8)
    assert edge_density(img) == 0.0
    img[8:24, 8:24] = 255  # a square: a one-pixel outline, 4 sides of 16 px
    rho = edge_density(np.dstack([img] * 3))
    # a thin outline: at most 4 x 16 + 16 pixels; non-maximum suppression may cut a corner pixel
    # or two per corner (OpenCV's four-direction NMS), never a side
    assert 56 / 1024 <= rho <= 80 / 1024
    from matcher.edges import canny_edges

    e = canny_edges(img, **CANNY_SETTINGS)
    sides = [e[6:10, 8:24].any(axis=0), e[22:26, 8:24].any(axis=0),
             e[8:24, 6:10].any(axis=1), e[8:24, 22:26].any(axis=1)]
    assert all(side[1:-1].all() for side in sides)  # every side found, ends aside


def _stripes(scene):
    """Fake left view: vertical square-wave stripes at the plane's frequency (64 x 48)."""
    f_px = scene.objects[0].texture.frequency * scene.objects[0].pose.translation[2] / RIG.fx
    x = np.arange(64)
    row = ((np.sin(2 * np.pi * f_px * x + 0.3) > 0) * 200).astype(np.uint8)
    return np.repeat(row[None], 48, axis=0)


def test_search_is_deterministic_and_hits_the_target_on_a_fake_renderer():
    base = scenes.get_preset("fronto_plane")
    a = match_edge_density(base, RIG, 0.2, render_left=_stripes)
    b = match_edge_density(base, RIG, 0.2, render_left=_stripes)
    assert a == b
    assert abs(a.edge_density - 0.2) <= 0.02 and a.probes <= 12
    assert a.scene.objects[0].texture.frequency == pytest.approx(
        a.frequency_px * RIG.fx / base.objects[0].pose.translation[2])


def test_search_returns_the_image_it_measured():
    base = scenes.get_preset("fronto_plane")
    r = match_edge_density(base, RIG, 0.2, render_left=_stripes)
    np.testing.assert_array_equal(r.left, _stripes(r.scene))
    assert r.edge_density == edge_density(r.left)
    assert not r.left.flags.writeable


def test_search_reports_an_unreachable_target():
    def blank(scene):
        return np.zeros((48, 64, 3), np.uint8)

    r = match_edge_density(scenes.get_preset("fronto_plane"), RIG, 0.2, render_left=blank)
    assert not r.converged and r.edge_density == 0.0


def test_search_validates_its_arguments():
    base = scenes.get_preset("fronto_plane")
    with pytest.raises(ValueError, match=r"target edge density must be in \(0, 1\)"):
        match_edge_density(base, RIG, 1.5, render_left=_stripes)
    with pytest.raises(ValueError, match="needs a renderer"):
        match_edge_density(base, RIG, 0.1)


@pytest.mark.gl
@pytest.mark.parametrize(
    ("preset", "targets"),
    [
        ("fronto_plane", (0.02, 0.05, 0.1, 0.2, 0.3)),
        ("slanted_plane", (0.02, 0.1, 0.3)),
        # at 64 x 48 the boxes' silhouettes alone give rho ~ 0.05 (at 640 x 480: ~0.007)
        ("boxes", (0.08, 0.15, 0.3)),
    ],
)
def test_measured_edge_density_is_within_0_02_of_the_request(renderer, preset, targets):
    base = retexture(scenes.get_preset(preset, seed=3), fx=RIG.fx, kind="noise", contrast=0.8)
    for target in targets:
        r = match_edge_density(base, RIG, target, renderer=renderer)
        assert abs(r.edge_density - target) <= 0.02, (preset, target, r)
        # the reported density is the one of the returned scene's left view
        assert edge_density(renderer.render_view(r.scene, RIG, eye="left").color) == \
            r.edge_density


@pytest.mark.gl
def test_target_below_the_geometry_floor_is_flagged(renderer):
    base = retexture(scenes.get_preset("boxes", seed=3), fx=RIG.fx, kind="noise")
    r = match_edge_density(base, RIG, 0.01, renderer=renderer)
    assert not r.converged and r.edge_density > 0.01 + SEARCH_TOL
