"""The rig's pose in a layout: height above the floor and pitch are exact rigid motions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import scenes
from scenes.layouts import outdoor, room
from scenes.posing import at_height, floor_height, pitched, posed
from scenes.sky import sky_colour
from stereoforge.errors import ParameterError


def _rx(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


@pytest.mark.parametrize("layout", [room, outdoor])
@settings(max_examples=8)  # each builds every mesh of a whole layout twice
@given(pitch=st.floats(-45.0, 45.0), seed=st.integers(0, 5))
def test_a_pitched_scene_is_the_scene_turned_about_the_baseline(layout, pitch, seed):
    """Every vertex of every object (furniture, terrain, trees, ...) of the pitched scene is
    ``Rx(pitch)`` of the level scene's, to 1e-9 m; the light turns with them."""
    level = layout(seed)
    turned = pitched(level, pitch)
    r = _rx(pitch)
    for a, b in list(zip(level.objects, turned.objects))[::3]:  # every kind, a third of each
        ma, mb = scenes.build_mesh(a), scenes.build_mesh(b)
        np.testing.assert_allclose(mb.vertices, ma.vertices @ r.T, atol=1e-9)
    np.testing.assert_allclose(turned.light.direction, r @ np.array(level.light.direction),
                               atol=1e-12)


def test_a_pitched_sky_keeps_its_colour_in_every_level_direction():
    level = outdoor(2)
    turned = pitched(level, 20.0)
    assert turned.sky.pitch == 20.0
    d = np.random.default_rng(0).normal(size=(400, 3))
    np.testing.assert_allclose(sky_colour(turned.sky, d @ _rx(20.0).T), sky_colour(level.sky, d),
                               atol=2e-6)


@pytest.mark.parametrize("layout", [room, outdoor])
def test_at_height_moves_everything_by_the_same_amount(layout):
    level = layout(1)
    moved = at_height(level, 0.7)
    assert floor_height(moved) == 0.7
    shifts = [b.pose.translation[1] - a.pose.translation[1]
              for a, b in zip(level.objects, moved.objects)]
    np.testing.assert_allclose(shifts, 0.7 - floor_height(level), atol=1e-12)
    assert all(a.pose.translation[::2] == b.pose.translation[::2]
               for a, b in zip(level.objects, moved.objects))


def test_pose_errors_name_the_key_and_the_fix():
    with pytest.raises(ParameterError, match="camera_height.*room.*outdoor"):
        at_height(scenes.get_preset("flying"), 1.0)
    with pytest.raises(ParameterError, match="pitch"):
        pitched(room(0), 60.0)
    assert posed(room(0)) == room(0) == pitched(room(0), 0.0)
