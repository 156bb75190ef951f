"""Textureless area under control: which share of the left image shows untextured surfaces.

The **textureless fraction** of a view is the share of its pixels whose first surface along the
pixel-centre ray belongs to an object with a ``"constant"`` texture (no pattern; Lambert shading
still varies on curved objects). It is measured, not estimated: :func:`object_coverage` renders
the left view once with every object painted one flat identity colour (ambient light only, so
the colour reaches the image unchanged) and counts each object's pixels. Pixels on silhouettes
where multisampling blends two colours decode to no object and count for none (about one pixel
along each silhouette). Making an object constant does not move any surface, so the counts hold
for the retextured scene too.

:func:`match_textureless` reaches a target: it visits the textured objects in a seeded order and
makes each constant when that brings the fraction closer to the target; objects already constant
count from the start. The result is exact for the scene it returns (same counts).
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from scenes import LightSpec, SceneSpec, TextureSpec

__all__ = ["object_coverage", "match_textureless"]


def _code(k: int) -> tuple[int, int, int]:
    """Identity colour of object ``k`` (1-based): three channels that blends rarely reproduce."""
    return (37 * k) % 251 + 1, (101 * k + 50) % 241 + 1, k % 250 + 3


def object_coverage(scene: SceneSpec, render_left: Callable[[SceneSpec], np.ndarray]
                    ) -> np.ndarray:
    """Pixels of the left view where each object is seen, an (n_objects,) int64 array.

    ``render_left(scene)`` renders the left view ((H, W, 3) uint8) of a scene.
    """
    painted = []
    for k, obj in enumerate(scene.objects, start=1):
        colour = tuple(c / 255.0 for c in _code(k))
        painted.append(dataclasses.replace(
            obj, texture=TextureSpec(kind="constant", mean=1.0, color=colour, contrast=0.0)))
    flat = dataclasses.replace(scene, objects=tuple(painted), background=(0.0, 0.0, 0.0),
                               light=LightSpec(intensity=0.0, ambient=1.0))
    image = np.asarray(render_left(flat)).astype(np.int64)
    key = (image[..., 0] << 16) | (image[..., 1] << 8) | image[..., 2]
    codes = np.array([(r << 16) | (g << 8) | b for r, g, b in
                      (_code(k) for k in range(1, len(scene.objects) + 1))])
    values, counts = np.unique(key, return_counts=True)
    lookup = dict(zip(values.tolist(), counts.tolist()))
    return np.array([lookup.get(int(c), 0) for c in codes], dtype=np.int64)


def match_textureless(scene: SceneSpec, target: float, coverage: np.ndarray, n_pixels: int,
                      rng: np.random.Generator) -> tuple[SceneSpec, float]:
    """``scene`` with objects made constant so that the textureless fraction nears ``target``.

    Returns the scene and its measured textureless fraction (from ``coverage``).
    """
    constant = [o.texture.kind == "constant" or o.texture.contrast == 0.0 for o in scene.objects]
    area = float(sum(int(c) for c, flat in zip(coverage, constant) if flat))
    chosen = set()
    for i in rng.permutation(len(scene.objects)):
        if constant[i]:
            continue
        grown = area + float(coverage[i])
        if abs(grown - target * n_pixels) < abs(area - target * n_pixels):
            area = grown
            chosen.add(int(i))
    objects = tuple(dataclasses.replace(o, texture=dataclasses.replace(
        o.texture, kind="constant", image="")) if i in chosen else o
        for i, o in enumerate(scene.objects))
    return dataclasses.replace(scene, objects=objects), area / n_pixels
