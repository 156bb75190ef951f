"""Hypothesis strategies for scene specifications, for property tests (ours and yours).

Needs ``hypothesis`` (a test dependency); ``import scenes`` does not import this module.

Examples
--------
>>> from hypothesis import given, settings
>>> from scenes.serialize import dumps_json, loads_json
>>> @settings(max_examples=5, deadline=None, derandomize=True)
... @given(scene_specs())
... def test_json_round_trip(spec):
...     assert loads_json(dumps_json(spec)) == spec
>>> test_json_round_trip()
"""

from __future__ import annotations

import math

from hypothesis import strategies as st

from scenes.materials import LAMP_KINDS, SPECULAR_MODELS, LampSpec, MaterialSpec
from scenes.spec import (
    MAX_EXTENT,
    OBJECT_KINDS,
    SKIMAGE_PHOTOS,
    TEXTURE_KINDS,
    LightSpec,
    ObjectSpec,
    Pose,
    SceneSpec,
    TextureSpec,
)

__all__ = ["texture_specs", "poses", "sizes", "object_specs", "light_specs", "material_specs",
           "lamp_specs", "scene_specs"]

_finite = st.floats(allow_nan=False, allow_infinity=False)
_unit = st.floats(min_value=0.0, max_value=1.0)
_positive = st.floats(min_value=1e-12, max_value=MAX_EXTENT)
_seed = st.integers(min_value=0, max_value=2**63 - 1)


def _vec3(elements: st.SearchStrategy[float]) -> st.SearchStrategy[tuple[float, float, float]]:
    return st.tuples(elements, elements, elements)


#: Object kinds that need no file (``"mesh"`` needs one: build it yourself).
_FILELESS_KINDS = tuple(k for k in OBJECT_KINDS if k != "mesh")


@st.composite
def texture_specs(draw: st.DrawFn, *, kinds: tuple[str, ...] = TEXTURE_KINDS) -> TextureSpec:
    """Valid :class:`TextureSpec` values of the given ``kinds`` (any finite numbers in range;
    ``"image"`` textures name a scikit-image photograph)."""
    kind = draw(st.sampled_from(kinds))
    image = ("skimage:" + draw(st.sampled_from(SKIMAGE_PHOTOS))) if kind == "image" else ""
    return TextureSpec(kind=kind, image=image,
                       frequency=draw(st.floats(min_value=0.0, exclude_min=True,
                                                allow_infinity=False)),
                       contrast=draw(_unit), mean=draw(_unit), color=draw(_vec3(_unit)),
                       seed=draw(_seed), angle=draw(_finite))


def poses() -> st.SearchStrategy[Pose]:
    """:class:`Pose` values with any translation within :data:`~scenes.spec.MAX_EXTENT` and any
    finite rotation."""
    return st.builds(Pose, translation=_vec3(st.floats(-MAX_EXTENT, MAX_EXTENT)),
                     rotation_deg=_vec3(_finite))


@st.composite
def sizes(draw: st.DrawFn, kind: str) -> tuple[float, ...]:
    """A valid ``size`` tuple for an object of ``kind``."""
    out = [draw(_positive) for _ in OBJECT_KINDS[kind]]
    if kind == "terrain":
        out[2] = draw(st.floats(min_value=0.0, max_value=1e3))
    if kind == "moebius":
        out[1] = min(out[0] * draw(st.floats(min_value=1e-3, max_value=1.99)), MAX_EXTENT)
    if kind in ("fence", "grid"):  # thickness < spacing
        out[3] = out[2] * draw(st.floats(min_value=1e-3, max_value=0.99))
        if not 0 < out[3] < out[2]:
            out[3] = out[2] / 2
    bound = {"torus": 0.99, "knot": 0.15, "wire": 0.25}.get(kind)
    if bound is not None:  # tube < radius, tube <= 0.15 radius, thickness <= 0.25 length
        out[1] = out[0] * draw(st.floats(min_value=1e-3, max_value=bound))
        if not 0 < out[1] <= bound * out[0]:
            out[1] = out[0] * bound / 2
    return tuple(out)


@st.composite
def object_specs(draw: st.DrawFn, *, kinds: tuple[str, ...] = _FILELESS_KINDS,
                 textures: st.SearchStrategy[TextureSpec] | None = None) -> ObjectSpec:
    """Valid :class:`ObjectSpec` values (pose, size, texture, name, segments, seed) of every kind
    but ``"mesh"`` (which needs a file)."""
    kind = draw(st.sampled_from(kinds))
    return ObjectSpec(kind, draw(poses()), draw(sizes(kind)),
                      draw(textures if textures is not None else texture_specs()),
                      name=draw(st.text(max_size=12)),
                      segments=draw(st.integers(min_value=3, max_value=4096)), seed=draw(_seed),
                      material=draw(st.one_of(st.just(MaterialSpec()), material_specs())))


def material_specs() -> st.SearchStrategy[MaterialSpec]:
    """:class:`MaterialSpec` values (matte ones included)."""
    return st.builds(MaterialSpec, specular=st.floats(0.0, 16.0),
                     shininess=st.floats(1.0, 10_000.0), model=st.sampled_from(SPECULAR_MODELS),
                     roughness=st.floats(0.02, 1.0))


def lamp_specs() -> st.SearchStrategy[LampSpec]:
    """:class:`LampSpec` values of either kind."""
    coord = st.floats(-1e6, 1e6)
    return st.builds(LampSpec, kind=st.sampled_from(LAMP_KINDS),
                     direction=_vec3(coord).filter(any), position=_vec3(coord),
                     intensity=st.floats(0.0, 1e6), shadows=st.booleans())


def light_specs() -> st.SearchStrategy[LightSpec]:
    """:class:`LightSpec` values with a direction of finite, non-zero length."""
    direction = _vec3(_finite).filter(lambda v: 0.0 < math.hypot(*v) < math.inf)
    return st.builds(LightSpec, direction=direction,
                     intensity=st.floats(min_value=0.0, allow_infinity=False),
                     ambient=st.floats(min_value=0.0, allow_infinity=False))


def scene_specs(*, max_objects: int = 4) -> st.SearchStrategy[SceneSpec]:
    """:class:`SceneSpec` values with 1 to ``max_objects`` objects."""
    return st.builds(SceneSpec, name=st.text(max_size=12),
                     objects=st.lists(object_specs(), min_size=1, max_size=max_objects).map(tuple),
                     light=light_specs(), background=_vec3(_unit), seed=_seed,
                     description=st.text(max_size=40),
                     lamps=st.lists(lamp_specs(), max_size=2).map(tuple))
