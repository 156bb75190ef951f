"""The rig's pose in a layout: the cameras' height above its floor and their pitch.

A scene lives in the left camera's frame, so moving the rig is moving the scene the other way:

- :func:`at_height` puts the cameras ``height`` metres above the layout's floor (the object
  named ``floor``, :func:`scenes.layouts.room`, or ``ground``, :func:`scenes.layouts.outdoor`,
  whose pose's ``y`` is the cameras' height above it): every object, lamp and point light is
  shifted along ``y`` by the difference;
- :func:`pitched` turns the rig about its baseline (the ``x`` axis through both optical centres,
  so the pair stays rectified) by ``pitch`` degrees, positive looking down: every pose, lamp,
  the light and the sky turn by ``Rx(pitch)`` (``X_camera = Rx(pitch) X_level``).

Both are exact rigid motions of the scene's data: the renderer's ground truth of the moved scene
is as exact as of any other.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from scenes.spec import LightSpec, ObjectSpec, Pose, SceneSpec
from stereoforge.validation import check_real, fail

__all__ = ["FLOOR_NAMES", "MAX_PITCH", "at_height", "pitched", "posed", "floor_height"]

#: Names of the objects whose pose's ``y`` is the cameras' height above a layout's floor.
FLOOR_NAMES = ("floor", "ground")
#: The largest pitch, degrees (beyond it a layout framed for a level rig shows its outside).
MAX_PITCH = 45.0


def floor_height(scene: SceneSpec) -> float | None:
    """The cameras' height above ``scene``'s floor (its first object named in
    :data:`FLOOR_NAMES`), or None when it has none.

    Examples
    --------
    >>> from scenes.layouts import room
    >>> 1.2 <= floor_height(room(0)) <= 1.8
    True
    """
    for obj in scene.objects:
        if obj.name in FLOOR_NAMES:
            return float(obj.pose.translation[1])
    return None


def _shift(obj: ObjectSpec, dy: float) -> ObjectSpec:
    x, y, z = obj.pose.translation
    return dataclasses.replace(obj, pose=dataclasses.replace(obj.pose, translation=(x, y + dy, z)))


def at_height(scene: SceneSpec, height: float) -> SceneSpec:
    """``scene`` with the cameras ``height`` metres above its floor (see the module docstring).

    Raises
    ------
    ParameterError
        If ``height`` is not positive or the scene has no floor.

    Examples
    --------
    >>> from scenes.layouts import room
    >>> floor_height(at_height(room(0), 0.6))
    0.6
    """
    height = check_real(height, "camera_height", lo=0.0, lo_open=True, hi=1e3)
    now = floor_height(scene)
    if now is None:
        raise fail("camera_height", f"a base with a floor (an object named {FLOOR_NAMES})",
                   f"scene {scene.name!r} without one",
                   fix="use base = 'room' or 'outdoor', or leave camera_height out")
    dy = height - now
    lamps = tuple(lamp if lamp.kind != "point" else dataclasses.replace(
        lamp, position=(lamp.position[0], lamp.position[1] + dy, lamp.position[2]))
        for lamp in scene.lamps)
    objects = [_shift(o, dy) for o in scene.objects]
    floor = next(i for i, o in enumerate(scene.objects) if o.name in FLOOR_NAMES)
    objects[floor] = _shift(objects[floor], height - objects[floor].pose.translation[1])
    return dataclasses.replace(scene, objects=tuple(objects), lamps=lamps)


def _rx(deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _euler(r: np.ndarray) -> tuple[float, float, float]:
    """Extrinsic x, y, z angles (degrees) of ``r = Rz(c) Ry(b) Rx(a)`` (:class:`Pose`)."""
    sb, cb = -float(r[2, 0]), math.hypot(r[0, 0], r[1, 0])
    if cb > 1e-12:  # atan2, not asin: b stays exact near +-90 degrees
        a = math.atan2(r[2, 1], r[2, 2])
        b = math.atan2(sb, cb)
        c = math.atan2(r[1, 0], r[0, 0])
    else:  # gimbal lock: only a - c (or a + c) is defined; put it all in a
        b = math.copysign(math.pi / 2, sb)
        a, c = math.atan2(-r[1, 2], r[1, 1]), 0.0
    return (math.degrees(a), math.degrees(b), math.degrees(c))


def _vec(r: np.ndarray, v: tuple[float, ...]) -> tuple[float, float, float]:
    out = r @ np.asarray(v, dtype=np.float64)
    return (float(out[0]), float(out[1]), float(out[2]))


def pitched(scene: SceneSpec, pitch: float) -> SceneSpec:
    """``scene`` seen by the rig turned ``pitch`` degrees about its baseline, positive looking
    down (see the module docstring).

    Examples
    --------
    >>> from scenes.layouts import room
    >>> spec = pitched(room(0), 10.0)
    >>> floor = spec.objects[0]
    >>> round(floor.pose.rotation_deg[0], 6)  # the floor plane, turned toward the cameras
    -80.0
    >>> pitched(room(0), 0.0) == room(0)
    True
    """
    pitch = check_real(pitch, "pitch", lo=-MAX_PITCH, hi=MAX_PITCH)
    if pitch == 0.0:
        return scene
    r = _rx(pitch)
    objects = tuple(dataclasses.replace(o, pose=Pose(
        translation=_vec(r, o.pose.translation),
        rotation_deg=_euler(r @ o.pose.rotation()))) for o in scene.objects)
    lamps = tuple(dataclasses.replace(lamp, direction=_vec(r, lamp.direction),
                                      position=_vec(r, lamp.position)) for lamp in scene.lamps)
    light = LightSpec(direction=_vec(r, scene.light.direction), intensity=scene.light.intensity,
                      ambient=scene.light.ambient)
    sky = None if scene.sky is None else dataclasses.replace(scene.sky,
                                                             pitch=scene.sky.pitch + pitch)
    return dataclasses.replace(scene, objects=objects, lamps=lamps, light=light, sky=sky)


def posed(scene: SceneSpec, *, camera_height: float | None = None, pitch: float | None = None
          ) -> SceneSpec:
    """``scene`` with the cameras at ``camera_height`` (:func:`at_height`), then turned by
    ``pitch`` (:func:`pitched`); None leaves either as it is."""
    if camera_height is not None:
        scene = at_height(scene, camera_height)
    return scene if pitch is None else pitched(scene, pitch)
