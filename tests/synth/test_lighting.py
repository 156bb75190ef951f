"""Lit scenes: Blinn-Phong highlights that move between views, shadows, masks, variants; GT exact."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scenes import LampSpec, LightSpec, MaterialSpec, ObjectSpec, Pose, SceneSpec, TextureSpec
from scenes.strategies import lamp_specs, material_specs
from stereoforge.errors import StereoforgeError
from synth.pair import expose, render_pair
from synth.render.lighting import HIGHLIGHT_LEVELS
from synth.camera.rig import StereoRig
from synth.testing import preset_scenes

RIG = StereoRig.default(96, 72, fx=80.0, baseline=0.2)
WHITE = TextureSpec(kind="constant", mean=1.0, contrast=0.0)


def _wall(z: float = 2.0, material: MaterialSpec = MaterialSpec()) -> ObjectSpec:
    return ObjectSpec("plane", Pose(translation=(0.0, 0.0, z)), (8.0, 6.0), WHITE,
                      material=material)


def _blinn_phong_plane(eye_x: float, *, z: float, ambient: float, intensity: float,
                       ks: float, shininess: float, roughness: float = 0.0) -> np.ndarray:
    """Closed form of a white fronto plane at depth z lit head-on (light travelling along +z),
    seen by the camera at (eye_x, 0, 0)."""
    u, v = np.meshgrid(np.arange(RIG.width), np.arange(RIG.height))
    p = np.stack([(u - RIG.cx) * z / RIG.fx + eye_x, (v - RIG.cy) * z / RIG.fy, np.full(u.shape, z)], -1)
    view = np.array([eye_x, 0.0, 0.0]) - p
    view /= np.linalg.norm(view, axis=-1, keepdims=True)
    half = view + np.array([0.0, 0.0, -1.0])
    half /= np.linalg.norm(half, axis=-1, keepdims=True)
    n_h = -half[..., 2]  # normal (0, 0, -1)
    if roughness:  # GGX with n . l = 1, so G1(l) = 1
        a2 = roughness ** 4
        n_v = -view[..., 2]
        g_v = 2 * n_v / (n_v + np.sqrt(a2 + (1 - a2) * n_v ** 2))
        lobe = a2 / (np.pi * (n_h ** 2 * (a2 - 1) + 1) ** 2) * g_v / (4 * n_v)
    else:
        lobe = n_h ** shininess
    linear = ambient + intensity + ks * intensity * lobe
    return 255.0 * np.clip(linear, 0.0, 1.0) ** (1 / 2.2)


@pytest.mark.gl
def test_blinn_phong_on_a_plane_matches_the_closed_form_in_both_views(renderer) -> None:
    ks, shininess, ambient, intensity = 0.45, 1000.0, 0.2, 0.3
    scene = SceneSpec("shiny wall", (_wall(material=MaterialSpec(ks, shininess)),),
                      light=LightSpec((0.0, 0.0, 1.0), intensity, ambient))
    pair = render_pair(scene, RIG, renderer=renderer)
    for image, eye_x in ((pair.left, 0.0), (pair.right, RIG.baseline)):
        want = _blinn_phong_plane(eye_x, z=2.0, ambient=ambient, intensity=intensity, ks=ks,
                                  shininess=shininess)
        assert np.abs(image[..., 1].astype(float) - want).max() <= 1.5
        # the highlight sits in front of each eye: at the principal point of both images,
        # not at the surface point's correspondence (d = 8 px away)
        row = image[int(RIG.cy), :, 1].astype(float)
        peak = np.flatnonzero(row == row.max())
        assert abs(peak.mean() - RIG.cx) <= 1.0
    d = RIG.fx * RIG.baseline / 2.0
    assert d == 8.0
    # the same surface point: left x, right x - d; its colour differs (view-dependent)
    x = int(RIG.cx)
    assert int(pair.left[36, x, 1]) - int(pair.right[36, x - int(d), 1]) >= 10


@pytest.mark.gl
def test_ggx_on_a_plane_matches_the_closed_form(renderer) -> None:
    ks, roughness, ambient, intensity = 0.05, 0.25, 0.2, 0.3
    material = MaterialSpec(ks, model="ggx", roughness=roughness)
    scene = SceneSpec("ggx wall", (_wall(material=material),),
                      light=LightSpec((0.0, 0.0, 1.0), intensity, ambient))
    pair = render_pair(scene, RIG, renderer=renderer)
    for image, eye_x in ((pair.left, 0.0), (pair.right, RIG.baseline)):
        want = _blinn_phong_plane(eye_x, z=2.0, ambient=ambient, intensity=intensity, ks=ks,
                                  shininess=1.0, roughness=roughness)
        assert want.max() - want.min() > 30  # a real highlight
        assert np.abs(image[..., 1].astype(float) - want).max() <= 1.5


def _ball_scene(material: MaterialSpec) -> SceneSpec:
    ball = ObjectSpec("sphere", Pose(translation=(0.0, 0.0, 1.6)), (0.35,), WHITE,
                      material=material, segments=32)
    wall = ObjectSpec("plane", Pose(translation=(0.0, 0.0, 2.5)), (6.0, 4.0),
                      TextureSpec(kind="checker", frequency=4.0))
    return SceneSpec("ball", (ball, wall), light=LightSpec((0.4, 0.6, 1.0), 0.8, 0.2))


@pytest.mark.gl
def test_specular_scene_keeps_the_ground_truth_of_its_matte_twin(renderer) -> None:
    matte = render_pair(_ball_scene(MaterialSpec()), RIG, renderer=renderer)
    shiny = render_pair(_ball_scene(MaterialSpec(0.8, 64.0)), RIG, renderer=renderer)
    for name in ("disp_left", "disp_right", "depth_left", "mask_left"):
        assert getattr(shiny, name).tobytes() == getattr(matte, name).tobytes(), name
    assert matte.highlight_left is None and matte.right_exposure is None
    hl, hr = shiny.highlight_left, shiny.highlight_right
    assert hl.dtype == np.uint8 and set(np.unique(hl)) == {0, 255}
    assert 20 <= (hl == 255).sum() <= 400
    assert not np.array_equal(hl, hr)  # the highlight moves between the views
    # against the same scene lit per fragment without the specular term (a dark lamp makes
    # it lit), the mask is where the image rises by the threshold (the mask samples pixel
    # centres, the image averages 4 samples: one level of slack)
    dark = LampSpec(intensity=0.0, shadows=False)
    diffuse = render_pair(dataclasses.replace(_ball_scene(MaterialSpec()), lamps=(dark,)), RIG,
                          renderer=renderer)
    assert diffuse.highlight_left is None
    for image, ref, mask in ((shiny.left, diffuse.left, hl), (shiny.right, diffuse.right, hr)):
        rise = (image.astype(int) - ref.astype(int)).max(-1)
        assert rise.min() >= 0
        assert rise[mask == 255].min() >= HIGHLIGHT_LEVELS - 1
        assert rise[mask == 0].max() <= HIGHLIGHT_LEVELS + 1


def _box_and_wall(lamp: LampSpec) -> SceneSpec:
    box = ObjectSpec("box", Pose(translation=(-0.3, 0.0, 1.5)), (0.4, 0.4, 0.4), WHITE)
    return SceneSpec("shadow", (box, _wall(2.5)), light=LightSpec((0.0, 0.0, 1.0), 0.0, 0.2),
                     lamps=(lamp,))


def _in_shadow(d: np.ndarray, z_wall: float) -> np.ndarray:
    """Left pixels on the wall whose ray toward the light meets the box (slab test)."""
    u, v = np.meshgrid(np.arange(RIG.width), np.arange(RIG.height))
    p = np.stack([(u - RIG.cx) * z_wall / RIG.fx, (v - RIG.cy) * z_wall / RIG.fy,
                  np.full(u.shape, z_wall)], -1)
    lo, hi = np.array([-0.5, -0.2, 1.3]), np.array([-0.1, 0.2, 1.7])
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - p) / -d, (hi - p) / -d
    near = np.nanmax(np.minimum(t0, t1), axis=-1)
    far = np.nanmin(np.maximum(t0, t1), axis=-1)
    return (near <= far) & (far > 0)


@pytest.mark.gl
@pytest.mark.parametrize("kind", ["directional", "point"])
def test_shadows_fall_where_the_box_blocks_the_lamp(renderer, kind: str) -> None:
    d = np.array([0.6, 0.0, 1.0]) / np.hypot(0.6, 1.0)
    pos = (-0.3 - 3.0 * d[0], 0.0, 1.5 - 3.0 * d[2])  # the point lamp on the same ray
    lamp = LampSpec(kind, direction=tuple(d), position=pos, intensity=0.6 if kind ==
                    "directional" else 0.6 * 9.0, shadows=True)
    lit = render_pair(_box_and_wall(lamp), RIG, renderer=renderer)
    free = render_pair(_box_and_wall(dataclasses.replace(lamp, shadows=False)), RIG,
                       renderer=renderer)
    dark = render_pair(_box_and_wall(dataclasses.replace(lamp, intensity=0.0)), RIG,
                       renderer=renderer)
    on_wall = np.abs(lit.depth_left - 2.5) < 1e-4
    if kind == "point":  # rays from the lamp, not parallel
        u, v = np.meshgrid(np.arange(RIG.width), np.arange(RIG.height))
        p = np.stack([(u - RIG.cx) * 2.5 / RIG.fx, (v - RIG.cy) * 2.5 / RIG.fy,
                      np.full(u.shape, 2.5)], -1)
        ray = p - np.asarray(pos)
        shadow = np.zeros(u.shape, bool)
        for i in range(RIG.height):
            for j in range(RIG.width):
                shadow[i, j] = _in_shadow(ray[i, j] / np.linalg.norm(ray[i, j]), 2.5)[i, j]
    else:
        shadow = _in_shadow(d, 2.5)
    from scipy import ndimage

    core = ndimage.binary_erosion(shadow & on_wall, iterations=2)
    clear = ndimage.binary_erosion(~shadow & on_wall, iterations=2)
    assert core.sum() >= 40 and clear.sum() >= 400
    diff_dark = np.abs(lit.left.astype(int) - dark.left.astype(int)).max(-1)
    diff_free = np.abs(lit.left.astype(int) - free.left.astype(int)).max(-1)
    assert diff_dark[core].max() <= 1  # in shadow: as if the lamp were off
    assert diff_free[clear].max() <= 1  # lit: as if there were no shadows (no acne)
    assert diff_free[core].min() >= 20
    assert lit.disp_left.tobytes() == dark.disp_left.tobytes()


@pytest.mark.gl
def test_exposure_and_lighting_variants(renderer) -> None:
    scene = _ball_scene(MaterialSpec(0.5, 32.0))
    relit = dataclasses.replace(scene, light=LightSpec((-0.5, 0.3, 1.0), 0.5, 0.3))
    pair = render_pair(scene, RIG, renderer=renderer, exposure=0.5, lighting=relit)
    assert np.array_equal(pair.right_exposure, expose(pair.right, 0.5))
    other = render_pair(relit, RIG, renderer=renderer)
    assert np.array_equal(pair.right_lighting, other.right)
    assert not np.array_equal(pair.right_lighting, pair.right)
    with pytest.raises(StereoforgeError, match="exposure"):
        render_pair(scene, RIG, renderer=renderer, exposure=0.0)
    moved = dataclasses.replace(scene, objects=scene.objects[:1])
    with pytest.raises(ValueError, match="lighting: expected the scene with only its lights"):
        render_pair(scene, RIG, renderer=renderer, lighting=moved)


def test_expose_is_a_linear_light_scaling() -> None:
    img = np.arange(256, dtype=np.uint8)[None]
    assert np.array_equal(expose(img, 1.0), img)
    lin = (img / 255.0) ** 2.2
    out = expose(img, 2.0)
    assert out[0, 255] == 255 and np.all(np.diff(out.astype(int)) >= 0)
    want = 255 * np.minimum(lin * 2.0, 1.0) ** (1 / 2.2)
    assert np.abs(out - want).max() <= 0.5


@pytest.mark.gl
def test_a_point_lamp_inside_the_scene_lights_it_by_the_inverse_square(renderer) -> None:
    lamp = LampSpec("point", position=(0.0, 0.0, 1.0), intensity=0.25, shadows=True)
    scene = SceneSpec("lamp", (_wall(2.0),), light=LightSpec((0.0, 0.0, 1.0), 0.0, 0.0),
                      lamps=(lamp,))
    pair = render_pair(scene, RIG, renderer=renderer)
    # at the principal point: distance 1 m, head-on: linear 0.25
    x, y = int(RIG.cx), int(RIG.cy)
    assert abs(float(pair.left[y, x, 0]) - 255 * 0.25 ** (1 / 2.2)) <= 1.5


@pytest.mark.gl
@settings(max_examples=6)
@given(base=preset_scenes(names=("boxes", "flying", "slanted_plane", "moebius")),
       material=material_specs(), lamps=st.lists(lamp_specs(), max_size=2).map(tuple),
       data=st.data())
def test_any_materials_and_lamps_keep_the_ground_truth(renderer, base, material, lamps,
                                                        data) -> None:
    """A property: materials and lamps (any, even shadowed point lamps inside the scene) never
    change a byte of the ground truth."""
    lamps = tuple(dataclasses.replace(lamp, intensity=min(lamp.intensity, 10.0)) for lamp in lamps)
    shiny = data.draw(st.lists(st.booleans(), min_size=len(base.objects),
                               max_size=len(base.objects)))
    objects = tuple(dataclasses.replace(o, material=material) if s else o
                    for o, s in zip(base.objects, shiny))
    lit = dataclasses.replace(base, objects=objects, lamps=lamps)
    rig = StereoRig.default(48, 36)
    a, b = render_pair(base, rig, renderer=renderer), render_pair(lit, rig, renderer=renderer)
    for name in ("disp_left", "disp_right", "depth_left", "mask_left"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes(), name
    assert (b.highlight_left is None) == (not lit.has_specular())
