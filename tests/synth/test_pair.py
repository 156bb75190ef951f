"""render_pair and the occlusion mask: structure, photometric check, an independent matcher."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import scenes

from synth.pair import (MASK_OCCLUDED, MASK_VISIBLE, StereoPair, ground_truth_from_depth,
                        occlusion_mask, render_pair)
from synth.render.renderer import Renderer
from synth.camera.rig import StereoRig


# ---------------------------------------------------------------------------- occlusion mask
def test_occlusion_mask_hand_picked_row() -> None:
    # background d = 1 everywhere; a foreground strip (d = 3) on left columns 5..7,
    # hence on right columns 2..4
    dl = np.array([[1, 1, 1, 1, 1, 3, 3, 3, 1, 1]], dtype=float)
    dr = np.array([[1, 1, 3, 3, 3, 1, 1, 1, 1, 1]], dtype=float)
    dl[0, 9] = np.inf  # no surface
    mask = occlusion_mask(dl, dr)
    # x=0: x-d=-1 (outside); x=3,4: background lands on right 2,3 (under the strip);
    # x=5..7: strip lands on 2..4 (visible); x=8: lands on 7, background (visible)
    assert mask.tolist() == [[128, 255, 255, 128, 128, 255, 255, 255, 255, 0]]


def test_occlusion_mask_special_values() -> None:
    # NaN and inf have no ground truth (0); x - d < -0.5 is outside (128); a right sample
    # that is inf (no surface) fails the interpolation but the other bracketing sample
    # still counts; float32 input is read as float64
    dl = np.array([[np.nan, 0.6, 0.4, 1.0, 1.5, np.inf]], dtype=np.float32)
    dr = np.array([[0.5, 0.4, np.inf, 1.5, 1.5, 1.5]], dtype=np.float32)
    # x=1: xr=0.4, a=dr[0]=0.5 is within 0.5 of 0.6 (not within 0); x=2: xr=1.6, a=0.4
    # equals d (b=inf); x=3: xr=2, a=inf and t=0 -> 128; x=4: xr=2.5, b=1.5 equals d
    assert occlusion_mask(dl, dr).tolist() == [[0, 255, 255, 128, 255, 0]]
    assert occlusion_mask(dl, dr, edge_tol=0.0).tolist() == [[0, 128, 255, 128, 255, 0]]


def test_occlusion_mask_validates_shapes() -> None:
    with pytest.raises(ValueError, match=r"\(H, W\) arrays of one shape"):
        occlusion_mask(np.zeros((4, 5)), np.zeros((4, 6)))


# ---------------------------------------------------------------------------- GL
@pytest.mark.gl
def test_pair_structure(renderer: Renderer) -> None:
    rig = StereoRig.default(40, 30)
    pair = render_pair(scenes.get_preset("boxes", seed=2), rig, renderer=renderer)
    assert isinstance(pair, StereoPair) and pair.rig is rig
    for name, shape, dtype in [("left", (30, 40, 3), np.uint8), ("right", (30, 40, 3), np.uint8),
                               ("disp_left", (30, 40), np.float32),
                               ("disp_right", (30, 40), np.float32),
                               ("depth_left", (30, 40), np.float32),
                               ("mask_left", (30, 40), np.uint8)]:
        arr = getattr(pair, name)
        assert arr.shape == shape and arr.dtype == dtype, name
        assert not arr.flags.writeable, name
    assert set(np.unique(pair.mask_left)) <= {0, 128, 255}
    np.testing.assert_allclose(pair.disp_left, rig.disparity_from_depth(pair.depth_left), rtol=1e-6)
    assert pair.meta["scene"] == "boxes" and pair.meta["seed"] == 2
    assert pair.meta["backend"] in ("egl", "osmesa") and pair.meta["renderer"]
    assert {"numpy", "PyOpenGL", "trimesh"} <= set(pair.meta["versions"])


@pytest.mark.gl
def test_occluded_pixels_are_hidden_by_something_nearer(renderer: Renderer) -> None:
    """Each 128 pixel inside the right frame lands where the right view sees a nearer surface."""
    rig = StereoRig(width=64, height=48, fx=120.0, fy=120.0, cx=31.5, cy=23.5, baseline=0.1)
    pair = render_pair(scenes.get_preset("boxes"), rig, renderer=renderer)
    rows, cols = np.nonzero(pair.mask_left == MASK_OCCLUDED)
    xr = cols - pair.disp_left[rows, cols]
    inside = xr >= -0.5
    assert inside.sum() > 20  # the boxes do occlude part of the wall
    r, x = rows[inside], xr[inside]
    x0, x1 = np.clip(np.floor(x).astype(int), 0, 63), np.clip(np.floor(x).astype(int) + 1, 0, 63)
    nearer = np.maximum(pair.disp_right[r, x0], pair.disp_right[r, x1])
    assert (nearer > pair.disp_left[r, cols[inside]] + 0.5).all()


def _warp_right(right: np.ndarray, disp: np.ndarray) -> np.ndarray:
    """Right image bilinearly sampled at (x - d, y)."""
    h, w = disp.shape
    xr = np.where(np.isfinite(disp), np.arange(w) - disp, 0.0)
    x0 = np.floor(xr).astype(int)
    t = (xr - x0)[..., None]
    rows = np.arange(h)[:, None]
    a = right[rows, np.clip(x0, 0, w - 1)].astype(np.float64)
    b = right[rows, np.clip(x0 + 1, 0, w - 1)].astype(np.float64)
    return a + t * (b - a)


def _interior(mask: np.ndarray, disp: np.ndarray) -> np.ndarray:
    """Visible pixels whose 3 x 3 neighbours are visible and within 1 px of disparity."""
    ok = mask == MASK_VISIBLE
    out = ok.copy()
    pad_ok, pad_d = np.pad(ok, 1), np.pad(disp, 1, mode="edge")
    h, w = ok.shape
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            out &= pad_ok[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
            with np.errstate(invalid="ignore"):
                out &= np.abs(pad_d[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] - disp) < 1.0
    return out


def _aimed_rig(point: tuple[float, float, float], *, fx: float = 1200.0) -> StereoRig:
    """64 x 48 rig at 2x the presets' zoom, principal point moved so ``point`` is centred."""
    X, Y, Z = point
    return StereoRig(width=64, height=48, fx=fx, fy=fx, cx=31.5 - fx * X / Z,
                     cy=23.5 - fx * Y / Z, baseline=0.05)


@pytest.mark.gl
def test_integer_disparity_shift_is_exact(renderer: Renderer) -> None:
    # fronto plane, d = 3 px: the right image is the left one moved 3 columns. The
    # texture is minified 10x here (deep mip levels): rounding may differ by a level or two.
    pair = render_pair(scenes.get_preset("fronto_plane"), StereoRig.default(64, 48),
                       renderer=renderer)
    diff = np.abs(pair.left[:, 3:].astype(int) - pair.right[:, :-3].astype(int))
    assert diff.max() <= 2 and (diff == 0).mean() >= 0.99


@pytest.mark.gl
@pytest.mark.parametrize("preset", ["slanted_plane", "boxes", "flying", "terrain"])
def test_photometric_consistency(renderer: Renderer, preset: str) -> None:
    """Right image sampled at x - d_left reproduces the left image (median |dI| <= 1).

    The presets' textures have ~8 px periods at their design zoom, where bilinear
    resampling alone attenuates them by up to 8 % (several grey levels): the rigs
    here zoom 2x (a 64 x 48 window aimed at each object, principal point far
    off-centre) so the test measures the renderer, not the interpolation.
    """
    spec = scenes.get_preset(preset, seed=1)
    tested = 0
    for obj in spec.objects[:3]:
        pair = render_pair(spec, _aimed_rig(obj.pose.translation), renderer=renderer)
        inner = _interior(pair.mask_left, pair.disp_left)
        if inner.mean() < 0.3:
            continue
        diff = np.abs(_warp_right(pair.right, pair.disp_left) - pair.left).mean(axis=-1)
        assert np.median(diff[inner]) <= 1.0, obj.name
        assert pair.left[inner].std() > 10  # textured: the check is not vacuous
        tested += 1
    assert tested >= 1


@pytest.mark.gl
@pytest.mark.slow
def test_sgbm_agrees_with_ground_truth(renderer: Renderer) -> None:
    """OpenCV's StereoSGBM, an independent matcher, finds our disparities on slanted_plane.

    A half-pixel convention error (principal point, pixel centres) would show
    as a 0.5 px median offset.
    """
    rig = StereoRig.default(640, 480)
    pair = render_pair(scenes.get_preset("slanted_plane"), rig, renderer=renderer)
    gray = [cv2.cvtColor(im, cv2.COLOR_RGB2GRAY) for im in (pair.left, pair.right)]
    sgbm = cv2.StereoSGBM_create(minDisparity=0, numDisparities=48, blockSize=5, P1=8 * 25,
                                 P2=32 * 25, uniquenessRatio=10, disp12MaxDiff=1)
    raw = sgbm.compute(*gray)  # int16, disparity * 16; -16 where invalid
    assert raw.dtype == np.int16
    valid = (raw >= 0) & _interior(pair.mask_left, pair.disp_left)
    assert valid.mean() > 0.8
    err = raw[valid] / 16.0 - pair.disp_left[valid]
    assert abs(np.median(err)) <= 0.1
    assert (np.abs(err) > 1.0).mean() <= 0.05


def test_ground_truth_from_depth_is_the_disparities_then_the_mask_of_them():
    """One pass = ``rig.disparity_from_depth`` of each view (float64), ``occlusion_mask`` of
    those, float32 disparities: on smooth and jumping depths and every special value."""
    rig = StereoRig.default(97, 31, baseline=0.12)
    rng = np.random.default_rng(5)
    x = np.arange(97)
    base = 1.5 + 0.01 * x[None, :] + 0.05 * np.arange(31)[:, None]  # a slanted plane
    seen: set[int] = set()
    for trial in range(20):
        zl = base + np.where(rng.random((31, 97)) < 0.2, rng.uniform(0, 3, (31, 97)), 0.0)
        zr = np.roll(zl, -int(rng.integers(0, 9)), axis=1)
        zl, zr = zl.astype(np.float32), zr.astype(np.float32)
        for z in (zl, zr):  # no surface, and depths no renderer gives (all mean "no truth")
            z[rng.random(z.shape) < 0.05] = np.inf
            if trial % 2:
                z[rng.random(z.shape) < 0.02] = rng.choice([0.0, -0.0, -1.0, np.nan])
        dl64, dr64 = rig.disparity_from_depth(zl), rig.disparity_from_depth(zr)
        dl, dr, mask = ground_truth_from_depth(rig, zl, zr)
        np.testing.assert_array_equal(dl, dl64.astype(np.float32))
        np.testing.assert_array_equal(dr, dr64.astype(np.float32))
        np.testing.assert_array_equal(mask, occlusion_mask(dl64, dr64))
        seen |= set(np.unique(mask).tolist())
    assert seen == {0, 128, 255}
