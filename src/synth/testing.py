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

__all__ = ["preset_scenes", "rendered_pairs"]


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
        Image size; the rig is :meth:`synth.rig.StereoRig.default` at that size.
    baseline : float
        Baseline in metres.
    names : tuple of str, optional
        Presets to draw from (default: all).
    """
    from synth.pair import render_pair
    from synth.rig import StereoRig

    rig = StereoRig.default(width, height, baseline=baseline)
    return preset_scenes(names=names).map(lambda scene: render_pair(scene, rig, renderer=renderer))
