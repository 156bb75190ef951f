"""Invariants of the renderer's ground truth: what must hold for any scene.

Each property has a hand-picked example beside it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from scenes import TextureSpec, build_meshes, get_preset
from synth.pair import render_pair
from synth.render.renderer import Renderer
from synth.camera.rig import StereoRig
from synth.testing import preset_scenes, rendered_pairs

pytestmark = pytest.mark.gl

RIG = StereoRig.default(64, 48)
SMALL = settings(max_examples=6, deadline=None)


def _near_discontinuity(d: np.ndarray, tol: float = 0.5) -> np.ndarray:
    """Pixels within 1 px of a jump in disparity (or of a pixel without ground truth)."""
    f = np.where(np.isfinite(d), d, -1e9)
    jump = np.zeros(d.shape, bool)
    jump[:, 1:] |= np.abs(np.diff(f, axis=1)) > tol
    jump[:, :-1] |= np.abs(np.diff(f, axis=1)) > tol
    jump[1:, :] |= np.abs(np.diff(f, axis=0)) > tol
    jump[:-1, :] |= np.abs(np.diff(f, axis=0)) > tol
    grown = jump.copy()
    grown[1:, :] |= jump[:-1, :]
    grown[:-1, :] |= jump[1:, :]
    grown[:, 1:] |= jump[:, :-1]
    grown[:, :-1] |= jump[:, 1:]
    return grown


def _retextured(scene, seed: int):
    rng = np.random.default_rng(seed)
    kinds = ["noise", "checker", "stripes", "constant"]
    objects = tuple(
        dataclasses.replace(
            o,
            texture=TextureSpec(kind=str(rng.choice(kinds)), frequency=float(rng.uniform(1, 20)),
                                contrast=float(rng.uniform(0, 1)), seed=int(rng.integers(0, 2**31))),
        )
        for o in scene.objects
    )
    return dataclasses.replace(scene, objects=objects)


# ---------------------------------------------------------------- disparity ignores the texture
def test_disparity_ignores_texture_hand_example(renderer: Renderer):
    scene = get_preset("boxes", seed=0)
    a = render_pair(scene, RIG, renderer=renderer)
    b = render_pair(_retextured(scene, 1), RIG, renderer=renderer)
    assert not np.array_equal(a.left, b.left)
    assert np.array_equal(a.disp_left, b.disp_left) and np.array_equal(a.disp_right, b.disp_right)
    assert np.array_equal(a.mask_left, b.mask_left)


@SMALL
@given(scene=preset_scenes(), seed=st.integers(0, 2**31 - 1))
def test_disparity_ignores_texture(renderer: Renderer, scene, seed):
    a = render_pair(scene, RIG, renderer=renderer)
    b = render_pair(_retextured(scene, seed), RIG, renderer=renderer)
    assert np.array_equal(a.disp_left, b.disp_left) and np.array_equal(a.disp_right, b.disp_right)


# ---------------------------------------------------------------- baseline and resolution
def test_doubling_the_baseline_doubles_disparity_hand_example(renderer: Renderer):
    scene = get_preset("fronto_plane")
    one = render_pair(scene, RIG, renderer=renderer)
    two = render_pair(scene, dataclasses.replace(RIG, baseline=2 * RIG.baseline), renderer=renderer)
    # fronto_plane sits at z = 2 m: d = 60 px * 0.1 m / 2 m = 3 px, then 6 px
    assert np.allclose(one.disp_left, 3.0, atol=1e-5) and np.allclose(two.disp_left, 6.0, atol=1e-5)


@SMALL
@given(scene=preset_scenes(), factor=st.floats(0.5, 3.0))
def test_scaling_the_baseline_scales_left_disparity(renderer: Renderer, scene, factor):
    one = render_pair(scene, RIG, renderer=renderer)
    other = render_pair(scene, dataclasses.replace(RIG, baseline=factor * RIG.baseline),
                        renderer=renderer)
    assert np.array_equal(np.isfinite(one.disp_left), np.isfinite(other.disp_left))
    ok = np.isfinite(one.disp_left)
    np.testing.assert_allclose(other.disp_left[ok], factor * one.disp_left[ok], rtol=1e-5, atol=1e-5)


def _sample_bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    tx, ty = x - x0, y - y0
    return ((1 - tx) * (1 - ty) * img[y0, x0] + tx * (1 - ty) * img[y0, x0 + 1]
            + (1 - tx) * ty * img[y0 + 1, x0] + tx * ty * img[y0 + 1, x0 + 1])


@pytest.mark.parametrize("factor", [2, 3])
def test_scaling_the_resolution_scales_disparity(renderer: Renderer, factor):
    # slanted_plane: disparity is affine in the pixel coordinates, so bilinear sampling of the
    # finer map at the coarse pixel centres is exact: (x, y) -> (f x + (f - 1) / 2, ...)
    scene = get_preset("slanted_plane")
    coarse = render_pair(scene, RIG, renderer=renderer)
    fine_rig = RIG.scaled(factor)
    fine = render_pair(scene, fine_rig, renderer=renderer)
    ys, xs = np.mgrid[1 : RIG.height - 1, 1 : RIG.width - 1].astype(float)
    sampled = _sample_bilinear(fine.disp_left.astype(np.float64), factor * xs + (factor - 1) / 2,
                               factor * ys + (factor - 1) / 2)
    np.testing.assert_allclose(sampled, factor * coarse.disp_left[1:-1, 1:-1], atol=1e-3)


# ---------------------------------------------------------------- mirror symmetry
def _mirrored(meshes: list[trimesh.Trimesh], baseline: float) -> list[trimesh.Trimesh]:
    """Reflect about the plane x = B / 2 (the rig's symmetry plane); keeps winding outward."""
    m = np.diag([-1.0, 1.0, 1.0, 1.0])
    m[0, 3] = baseline
    out = []
    for mesh in meshes:
        copy = mesh.copy()
        copy.apply_transform(m)  # trimesh flips the faces of a reflection
        out.append(copy)
    return out


def _mirror_check(renderer: Renderer, scene) -> None:
    rig = RIG  # centred principal point: mirroring x about B/2 flips image columns exactly
    meshes = build_meshes(scene)
    a = render_pair(meshes, rig, renderer=renderer)
    b = render_pair(_mirrored(meshes, rig.baseline), rig, renderer=renderer)
    expect_left, expect_right = a.disp_right[:, ::-1], a.disp_left[:, ::-1]
    for got, want in ((b.disp_left, expect_left), (b.disp_right, expect_right)):
        away = ~_near_discontinuity(want)
        assert np.array_equal(np.isfinite(got[away]), np.isfinite(want[away]))
        ok = away & np.isfinite(want)
        np.testing.assert_allclose(got[ok], want[ok], atol=1e-3)
        assert ok.mean() > 0.5


def test_mirrored_scene_swaps_the_views_hand_example(renderer: Renderer):
    _mirror_check(renderer, get_preset("boxes", seed=3))


@SMALL
@given(scene=preset_scenes())
def test_mirrored_scene_swaps_the_views(renderer: Renderer, scene):
    _mirror_check(renderer, scene)


# ---------------------------------------------------------------- the importable strategy
@settings(max_examples=4, deadline=None)
@given(data=st.data())
def test_rendered_pairs_strategy(renderer: Renderer, data):
    pair = data.draw(rendered_pairs(renderer, width=64, height=48))
    assert pair.left.shape == (48, 64, 3) and pair.disp_left.shape == (48, 64)
    assert set(np.unique(pair.mask_left)) <= {0, 128, 255}
    assert np.all(pair.disp_left[np.isfinite(pair.disp_left)] >= 0)


def test_preset_scenes_rejects_unknown_names():
    with pytest.raises(ValueError, match="valid presets"):
        preset_scenes(names=("nope",))
