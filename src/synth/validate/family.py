"""The base scenes of ``stereoforge validate``: each seed of a suite draws its own.

A suite's seed ``k`` takes member ``k mod len(FAMILY)`` of :data:`FAMILY` and draws that member's
free choices (how many occluders and where they sit, which texture, which photographs) from
``numpy.random.default_rng(k)``; the preset's own seed and the occluders' positions then come
from the sample's seed, as in any dataset (:mod:`synth.dataset.config.sampling`). The result is the
``[scene]`` table of a dataset config with **fixed values only** (no distribution of the
parameter stream), so an axis that sets one key changes that key and no other draw.

The members, in order (the quick suite's three seeds cover the first three):

- ``boxes``: four boxes in front of a wall, 1-3 extra box occluders, noise texture;
- ``flying``: 6-10 boxes, spheres and cylinders (layout from the seed), photographs on about
  a third of the objects (the wall included), noise on the others;
- ``slanted``: a slanted plane behind 2-3 spheres or cylinders, photographs or noise;
- ``moebius``: a Moebius strip (a curved, twisted surface) in front of a wall, one occluder,
  photographs.

Photographs are scikit-image's brick, gravel and grass (no download): their mean frequencies
(0.07-0.15 cycles per photo pixel) are near the textures' 0.125 cycles per image pixel, and a
photograph is sampled at one texel per photo pixel, so these cost about what a noise texture
does; the colour ones (0.02-0.04) made a pair 5-10 times slower to texture. Two axes need
procedural textures and drop the photographs of a member (``edge_density``: the closed-loop
search; ``repetitive_period``: stripes).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["FAMILY", "PHOTOS", "PHOTO_KEYS", "base_scene", "member_name"]

#: The photographs a member with photo textures draws from, per object.
PHOTOS = ("skimage:brick", "skimage:gravel", "skimage:grass")
#: The [scene] keys that put photographs on objects (dropped by axes that need other textures).
PHOTO_KEYS = ("object_texture", "object_image")


def _photos(weight_noise: int) -> dict:
    """Per-object textures: a photograph, or noise with odds ``weight_noise`` to 1."""
    return {"object_texture": {"choice": ["image"] + ["noise"] * weight_noise},
            "object_image": {"choice": list(PHOTOS)}}


def _boxes(rng: np.random.Generator) -> dict:
    return {"base": "boxes", "texture": "noise", "occluders": int(rng.integers(1, 4)),
            "occluder_kind": "box", "occluder_depth": round(float(rng.uniform(1.3, 1.7)), 2)}


def _flying(rng: np.random.Generator) -> dict:
    return {"base": "flying", "texture": "noise", **_photos(2)}


def _slanted(rng: np.random.Generator) -> dict:
    photos = _photos(0) if rng.random() < 0.5 else {}
    return {"base": "slanted_plane", "texture": "noise", **photos,
            "occluders": int(rng.integers(2, 4)),
            "occluder_kind": str(rng.choice(["sphere", "cylinder"])),
            "occluder_size": round(float(rng.uniform(0.12, 0.2)), 3),
            "occluder_depth": round(float(rng.uniform(1.4, 1.9)), 2)}


def _moebius(rng: np.random.Generator) -> dict:
    return {"base": "moebius", "texture": "noise", "occluders": 1,
            "occluder_kind": str(rng.choice(["box", "sphere"])),
            "occluder_depth": round(float(rng.uniform(1.2, 1.6)), 2), **_photos(0)}


#: ``(name, draw)``: ``draw(rng)`` returns the member's [scene] keys.
FAMILY: tuple[tuple[str, Callable[[np.random.Generator], dict]], ...] = (
    ("boxes", _boxes), ("flying", _flying), ("slanted", _slanted), ("moebius", _moebius))


def member_name(seed: int) -> str:
    """The family member seed ``seed`` of a suite draws.

    Examples
    --------
    >>> [member_name(k) for k in range(5)]
    ['boxes', 'flying', 'slanted', 'moebius', 'boxes']
    """
    return FAMILY[int(seed) % len(FAMILY)][0]


def base_scene(seed: int) -> dict:
    """The ``[scene]`` keys of seed ``seed``'s base scene (a new dict): every texture at 0.125
    cycles per pixel (an 8 px period, a photograph's mean frequency) and contrast 0.8.

    Examples
    --------
    >>> base_scene(0) == base_scene(0) != base_scene(4)
    True
    >>> base_scene(1)["base"], base_scene(1)["object_image"]["choice"][0]
    ('flying', 'skimage:brick')
    """
    _, draw = FAMILY[int(seed) % len(FAMILY)]
    return {**draw(np.random.default_rng(int(seed))), "frequency_px": 0.125, "contrast": 0.8}
