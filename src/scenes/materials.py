"""Materials and lamps of a scene: a Blinn-Phong specular term per object, extra lights.

A scene is *matte* when no object has a specular term and it has no lamps: it is then lit by
its single classic :class:`scenes.spec.LightSpec` through a view-independent Lambert shade baked
per vertex (the renderer's original path, whose bytes never change). A scene with a specular
material or a lamp is *lit*: the renderer evaluates, per fragment and with the view direction of
the eye being rendered,

    radiance = albedo * (ambient + sum_k E_k * max(n . l_k, 0))
             + specular * sum_k E_k * lobe(n, l_k, v)   [n . l_k > 0]

with the Blinn-Phong lobe ``max(n . h_k, 0) ** shininess`` or the GGX lobe (:class:`MaterialSpec`),

in linear light (albedo = the display-encoded texture x tint raised to the display gamma), over
the classic light (unshadowed) and every lamp (shadowed when ``shadows``), then encodes the result
with the display gamma. ``h_k`` is the half vector of ``l_k`` and the direction toward the eye,
so highlights move between the two views while diffuse shading does not.
The round trip of these dataclasses lives in :mod:`scenes.spec` with every other scene table.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from stereoforge.validation import check_bool, check_choice, check_real, check_sequence, check_type, fail

__all__ = ["LAMP_KINDS", "MAX_LAMPS", "SPECULAR_MODELS", "MaterialSpec", "LampSpec", "turn_lights"]

#: Specular lobes: Blinn-Phong (``shininess``) or GGX / Trowbridge-Reitz (``roughness``).
SPECULAR_MODELS: tuple[str, ...] = ("blinn-phong", "ggx")
#: Lamp kinds: a directional light (parallel rays) or a point light (inverse-square falloff).
LAMP_KINDS: tuple[str, ...] = ("directional", "point")
#: Lamps a scene may hold (the renderer's uniform arrays: the classic light takes one more slot).
MAX_LAMPS = 7
_MAX_SHININESS = 10_000.0
_MAX_SPECULAR = 16.0


def _set(obj: object, name: str, value: object) -> None:
    object.__setattr__(obj, name, value)


def _vec3(value: object, name: str) -> tuple[float, ...]:
    return check_sequence(value, name, length=3, of="numbers",
                          item=lambda v, item: check_real(v, item, lo=-1e6, hi=1e6))


@dataclass(frozen=True)
class MaterialSpec:
    """The reflectance of one object beyond its texture: a Blinn-Phong or GGX specular lobe.

    Parameters
    ----------
    specular : float
        Strength ``k_s`` of the specular term in [0, 16] (0: matte, the default). A white
        highlight of a light of intensity ``E`` head-on adds ``k_s * E`` to the linear radiance.
    shininess : float
        Blinn-Phong exponent in [1, 10000]: larger is a smaller, sharper highlight (8: plastic
        under a broad lobe, 64: glossy paint, 512: polished).
    model : {"blinn-phong", "ggx"}
        The lobe. ``"ggx"``: the microfacet lobe ``D(h) G1(l) G1(v) / (4 n.v)`` per unit
        irradiance, with the GGX (Trowbridge-Reitz) distribution ``D`` of ``alpha = roughness**2``
        and Smith's separable masking ``G1``, no Fresnel term (``specular`` scales it).
    roughness : float
        GGX roughness in [0.02, 1] (ignored by Blinn-Phong): 0.1 polished, 0.5 satin.

    Examples
    --------
    >>> MaterialSpec(specular=0.6, shininess=64.0).is_matte()
    False
    """

    specular: float = 0.0
    shininess: float = 32.0
    model: str = "blinn-phong"
    roughness: float = 0.3

    def __post_init__(self) -> None:
        check_choice(check_type(self.model, "MaterialSpec.model", str), "MaterialSpec.model",
                     SPECULAR_MODELS)
        _set(self, "roughness", check_real(self.roughness, "MaterialSpec.roughness", lo=0.02,
                                           hi=1.0))
        _set(self, "specular", check_real(self.specular, "MaterialSpec.specular", lo=0.0,
                                          hi=_MAX_SPECULAR))
        _set(self, "shininess", check_real(self.shininess, "MaterialSpec.shininess", lo=1.0,
                                           hi=_MAX_SHININESS,
                                           fix="a Blinn-Phong exponent such as 32"))

    def is_matte(self) -> bool:
        """True when the material adds no specular term."""
        return self.specular == 0.0


@dataclass(frozen=True)
class LampSpec:
    """A light added to a scene's classic light (a scene with lamps is rendered lit).

    Parameters
    ----------
    kind : {"directional", "point"}
        ``"directional"``: parallel rays travelling along ``direction``; ``"point"``: a point at
        ``position`` whose irradiance falls off as ``intensity / r**2`` (``r`` in metres).
    direction : (3,) tuple of float
        Direction the light travels (light -> scene), world frame (y down); non-zero. Used by
        directional lamps.
    position : (3,) tuple of float
        World position (metres) of a point lamp; with shadows it must lie outside the scene's
        bounding sphere (one shadow map looks at the scene from there).
    intensity : float
        >= 0: the irradiance of a directional lamp, the irradiance at 1 m of a point lamp.
    shadows : bool
        Cast shadows (one shadow map per lamp, see ``docs/ground-truth.md``).

    Examples
    --------
    >>> LampSpec("point", position=(0.0, -2.0, 1.0), intensity=2.0).kind
    'point'
    """

    kind: str = "directional"
    direction: tuple[float, float, float] = (0.3, 0.5, 1.0)
    position: tuple[float, float, float] = (0.0, -2.0, 0.0)
    intensity: float = 0.5
    shadows: bool = True

    def __post_init__(self) -> None:
        check_choice(check_type(self.kind, "LampSpec.kind", str), "LampSpec.kind", LAMP_KINDS)
        direction = _vec3(self.direction, "LampSpec.direction")
        if not any(direction):
            raise fail("LampSpec.direction", "a non-zero 3-vector", repr(direction),
                       fix="give a direction such as (0.3, 0.5, 1.0)")
        _set(self, "direction", direction)
        _set(self, "position", _vec3(self.position, "LampSpec.position"))
        _set(self, "intensity", check_real(self.intensity, "LampSpec.intensity", lo=0.0,
                                           hi=1e6))
        _set(self, "shadows", check_bool(self.shadows, "LampSpec.shadows"))


def _rotate(v: np.ndarray, axis: np.ndarray, degrees: float) -> np.ndarray:
    """``v`` turned by ``degrees`` about the unit ``axis`` (Rodrigues)."""
    t = np.deg2rad(degrees)
    return v * np.cos(t) + np.cross(axis, v) * np.sin(t) + axis * (axis @ v) * (1 - np.cos(t))


def _turned(v: np.ndarray, degrees: float, rng: np.random.Generator) -> tuple[float, ...]:
    """``v`` turned by ``degrees`` about a random axis perpendicular to it."""
    axis = np.cross(v, rng.normal(size=3))
    if not np.linalg.norm(axis) > 0:  # a point lamp at the scene centre stays there
        return tuple(float(c) for c in v)
    return tuple(float(c) for c in _rotate(v, axis / np.linalg.norm(axis), degrees))


def turn_lights(scene: Any, degrees: float, rng: np.random.Generator) -> tuple[Any, tuple[LampSpec, ...]]:
    """A scene's light and lamps with every direction turned by ``degrees`` (another lighting).

    The classic light's direction and each directional lamp's direction turn about a random
    axis perpendicular to them; each point lamp turns the same way about the scene centre
    ``(0, 0, z)`` (``z`` the median depth of the objects). The axes come from ``rng``. This is
    the ``im1L`` relighting of datasets (``lighting_variant``) and of ``stereoforge render``.

    Returns
    -------
    (scenes.LightSpec, tuple of LampSpec)

    Examples
    --------
    >>> import scenes
    >>> spec = scenes.get_preset("fronto_plane")
    >>> light, lamps = turn_lights(spec, 30.0, np.random.default_rng(0))
    >>> round(float(np.degrees(np.arccos(light.unit_direction() @ spec.light.unit_direction()))), 6)
    30.0
    """
    degrees = check_real(degrees, "lighting variant (degrees)", lo=0.0, hi=180.0)
    light = dataclasses.replace(scene.light,
                                direction=_turned(scene.light.unit_direction(), degrees, rng))
    centre = np.array([0.0, 0.0, float(np.median([o.pose.translation[2] for o in scene.objects]))])
    lamps = []
    for lamp in scene.lamps:
        if lamp.kind == "directional":
            new = {"direction": _turned(np.asarray(lamp.direction, dtype=np.float64), degrees, rng)}
        else:
            v = np.asarray(lamp.position, dtype=np.float64) - centre
            new = {"position": tuple(float(c) for c in np.asarray(_turned(v, degrees, rng)) + centre)}
        lamps.append(dataclasses.replace(lamp, **new))
    return light, tuple(lamps)
