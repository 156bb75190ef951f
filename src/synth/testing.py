"""Hypothesis strategies for rendered stereo pairs (needs an OpenGL backend).

The GL-free strategies (images, shifted pairs, piecewise-planar pairs) are in
:mod:`matcher.testing`. These draw whole scenes, render them with exact ground truth and hand you a
:class:`synth.pair.StereoPair`, so a matcher can be property-tested on geometry with occlusions::

    from hypothesis import given, settings
    from synth.render.renderer import Renderer
    from synth.testing import rendered_pairs

    RENDERER = Renderer(96, 72)

    @settings(max_examples=10, deadline=None)
    @given(rendered_pairs(RENDERER, width=96, height=72))
    def test_my_matcher_on_rendered_scenes(pair):
        disp = my_matcher(pair.left, pair.right)
        visible = pair.mask_left == 255
        assert abs(disp[visible] - pair.disp_left[visible]).mean() < 2.0
"""

from __future__ import annotations

from hypothesis import strategies as st

from scenes import SceneSpec, get_preset, list_presets

__all__ = ["preset_scenes", "rendered_pairs", "rig_errors"]


def preset_scenes(*, names: tuple[str, ...] | None = None) -> st.SearchStrategy[SceneSpec]:
    """Scenes drawn from the built-in presets with random seeds.

    Every preset frames the default rig's views (fx = 600 px per 640 px of width), and its seed
    changes its textures (and, for ``flying``, its layout: 6-10 random boxes, spheres and
    cylinders in front of a wall).
    """
    valid = [name for name, _ in list_presets()]
    chosen = list(names) if names is not None else valid
    unknown = sorted(set(chosen) - set(valid))
    if unknown:
        raise ValueError(f"unknown preset(s) {unknown}; valid presets: {', '.join(valid)}")
    return st.builds(lambda name, seed: get_preset(name, seed=seed),
                     st.sampled_from(chosen), st.integers(0, 2**31 - 1))


def rendered_pairs(renderer, *, width: int = 64, height: int = 48, baseline: float = 0.1,
                   names: tuple[str, ...] | None = None) -> st.SearchStrategy:
    """Rendered :class:`synth.pair.StereoPair` values of random preset scenes.

    Parameters
    ----------
    renderer : synth.render.Renderer
        An open renderer (one GL context for all examples).
    width, height : int
        Image size; the rig is :meth:`synth.camera.rig.StereoRig.default` at that size.
    baseline : float
        Baseline in metres.
    names : tuple of str, optional
        Presets to draw from (default: all).
    """
    from synth.pair import render_pair
    from synth.camera.rig import StereoRig

    rig = StereoRig.default(width, height, baseline=baseline)
    return preset_scenes(names=names).map(lambda scene: render_pair(scene, rig, renderer=renderer))


def rig_errors(*, max_k1: float = 0.2, max_rotation_deg: float = 2.0,
               max_dy_px: float = 2.0) -> st.SearchStrategy:
    """Small, realistic :class:`synth.camera.lens.RigErrors`: distortion of both cameras (``|k1| <=
    max_k1``, ``|k2| <= max_k1 / 4``, ``|p1|, |p2| <= 0.002``), a rotation of the right camera
    within ``max_rotation_deg`` per axis, a vertical offset within ``max_dy_px`` and a focal
    ratio in [0.97, 1.03]. They never fold a view of up to ~60 degrees.

    Use with ``dataclasses.replace(rig, errors=...)`` and ``render_pair``: the pair then carries
    the exact ``flow_left`` of its real cameras.
    """
    from synth.camera.lens import Distortion, RigErrors

    def distortions() -> st.SearchStrategy:
        return st.builds(Distortion, st.floats(-max_k1, max_k1), st.floats(-max_k1 / 4, max_k1 / 4),
                         st.floats(-0.002, 0.002), st.floats(-0.002, 0.002), st.just(0.0))

    angle = st.floats(-max_rotation_deg, max_rotation_deg)
    return st.builds(RigErrors, left=distortions(), right=distortions(),
                     rotation_deg=st.tuples(angle, angle, angle),
                     dy_px=st.floats(-max_dy_px, max_dy_px), f_scale=st.floats(0.97, 1.03))
