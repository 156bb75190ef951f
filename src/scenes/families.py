"""Procedural object families: seeded builders of local meshes, and the deformations that bend
them.

A family is a kind of object whose shape the seed draws: ``FAMILY_BUILDERS[kind](size, segments,
seed)`` returns the local mesh of :mod:`scenes.primitives` (``verts`` (N, 3) float64, ``faces``
(M, 3) int64, ``coords`` (N, 2) float64 surface coordinates in metres, ``extent`` = the atlas'
(width, height) in metres) centred on the origin in the object frame (``y`` down, so "up" is
``-y``; right-handed). ``size`` is in metres with the labels of :data:`FAMILY_SIZES`;
:func:`family_size_problem` states what else a size must satisfy. Each builder's docstring gives
the exact box or radius its vertices lie in. The same ``(size, segments, seed)`` gives the same
bits; randomness comes only from ``np.random.default_rng(seed)``. ``segments`` (3..4096) sets the
tessellation; at 64 a solid has under 20k triangles, a plant under 30k.

Closed families are watertight once texture-seam duplicates are merged, wound counter-clockwise
seen from outside, of positive volume. :data:`OPEN_FAMILIES` (trees and bushes: their leaves are
single quads) must be rendered double-sided.

The builders live by subject: :mod:`scenes.solids` (superquadric, rock, torus, knot, polyhedron,
wire), :mod:`scenes.vessels` (revolution), :mod:`scenes.extrusions` (extrusion),
:mod:`scenes.vegetation` (tree, bush) and :mod:`scenes.furniture`; their shared blocks (tubes
on rotation-minimising frames, lathing, boxes, edge splitting) are the package-private
:mod:`scenes._meshkit`.
This module holds the registry and two mesh operations for any local mesh: :func:`deform`
(taper, twist, bend about local ``y``; Barr 1984) and :func:`subdivide` (split long edges so a
deformation bends flat faces smoothly).

References
----------
A. H. Barr, "Global and local deformations of solid primitives", SIGGRAPH 1984.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from scenes._meshkit import LocalMesh, split_edges
from scenes.extrusions import extrusion
from scenes.furniture import furniture
from scenes.solids import (
    KNOT_TUBE_RATIO,
    WIRE_THICKNESS_RATIO,
    knot,
    polyhedron,
    rock,
    superquadric,
    torus,
    wire,
)
from scenes.vegetation import bush, tree
from scenes.vessels import revolution

__all__ = ["FAMILY_BUILDERS", "FAMILY_SIZES", "OPEN_FAMILIES", "LocalMesh", "family_size_problem",
           "deform", "subdivide", "KNOT_TUBE_RATIO", "WIRE_THICKNESS_RATIO"]

#: kind -> builder(size, segments, seed) -> LocalMesh (a ``(verts, faces, coords, extent)`` tuple)
FAMILY_BUILDERS: dict[str, Callable[[tuple[float, ...], int, int], LocalMesh]] = {
    "superquadric": superquadric, "rock": rock, "torus": torus, "knot": knot,
    "revolution": revolution, "extrusion": extrusion, "polyhedron": polyhedron, "tree": tree,
    "bush": bush, "wire": wire, "furniture": furniture}

#: kind -> the labels of its size values (metres, all > 0)
FAMILY_SIZES: dict[str, tuple[str, ...]] = {
    "superquadric": ("sx", "sy", "sz"), "rock": ("radius",), "torus": ("radius", "tube"),
    "knot": ("radius", "tube"), "revolution": ("radius", "height"),
    "extrusion": ("radius", "depth"), "polyhedron": ("radius",), "tree": ("width", "height"),
    "bush": ("width", "height"), "wire": ("length", "thickness"),
    "furniture": ("sx", "sy", "sz")}

#: Families with open surfaces (leaves): render them double-sided.
OPEN_FAMILIES: frozenset[str] = frozenset({"tree", "bush"})


def family_size_problem(kind: str, size: tuple[float, ...]) -> str | None:
    """What is wrong with ``size`` for a family ``kind``, or None if it is fine.

    Beyond the count of values and their positivity: a torus needs ``tube < radius``, a knot
    ``tube <= KNOT_TUBE_RATIO * radius`` (its tube would meet itself), a wire
    ``thickness <= WIRE_THICKNESS_RATIO * length``.

    Examples
    --------
    >>> family_size_problem("knot", (1.0, 0.1)) is None
    True
    >>> family_size_problem("torus", (0.5, 0.5))
    'torus needs tube < radius, got tube 0.5 and radius 0.5'
    """
    if kind not in FAMILY_SIZES:
        return f"unknown family {kind!r}; families are {sorted(FAMILY_SIZES)}"
    labels = FAMILY_SIZES[kind]
    if len(size) != len(labels):
        return f"{kind} needs {len(labels)} size values {labels}, got {len(size)}"
    if not all(np.isfinite(s) and s > 0 for s in size):
        return f"{kind} size values {labels} must be finite and > 0, got {tuple(size)}"
    a, b = size[0], size[-1]
    if kind == "torus" and not b < a:
        return f"torus needs tube < radius, got tube {b} and radius {a}"
    if kind == "knot" and not b <= KNOT_TUBE_RATIO * a:
        return (f"knot needs tube <= {KNOT_TUBE_RATIO} * radius (or the tube meets itself), "
                f"got tube {b} and radius {a}")
    if kind == "wire" and not b <= WIRE_THICKNESS_RATIO * a:
        return f"wire needs thickness <= {WIRE_THICKNESS_RATIO} * length, got {b} and {a}"
    return None


def deform(verts: np.ndarray, *, extent: float, twist: float = 0.0, bend: float = 0.0,
           taper: float = 0.0) -> np.ndarray:
    """Taper, then twist, then bend local vertices about the local ``y`` axis (Barr 1984).

    With ``t = y / (extent / 2)`` (-1 at the top ``y = -extent/2``, +1 at the bottom):

    - taper: ``x`` and ``z`` scale by ``1 + taper * t`` (``taper`` in (-1, 1)); the middle
      ``t = 0`` keeps its size, a positive taper widens the bottom.
    - twist: a rotation about ``y`` by ``twist * t / 2`` radians, so ``twist`` is the total angle
      between top and bottom (the distance to the ``y`` axis is kept).
    - bend: the ``y`` axis becomes a circular arc in the x-y plane of the same length, turning by
      ``bend`` radians in all (``bend / 2`` each side of ``y = 0``, which stays put); positive
      ``bend`` curves both ends toward ``+x``. Each slice ``y = const`` stays perpendicular to
      the arc and keeps its distances; ``bend = 0`` is the identity.

    A parameter at zero leaves the vertices exactly (bit for bit) as they are. Deformed vertices
    may leave the undeformed bounding box (a taper widens one end by up to ``1 + |taper|``).
    Split long edges first (:func:`subdivide`) to bend flat faces smoothly.

    Parameters
    ----------
    verts : (N, 3) float64 array
        Local vertices.
    extent : float
        The object's extent along local ``y`` (its height, > 0).
    twist, bend, taper : float
        Total twist and bend angles (radians), taper factor.

    Returns
    -------
    verts : (N, 3) float64 array
        A new array.

    Examples
    --------
    >>> v = np.array([[1.0, -1.0, 0.0], [1.0, 1.0, 0.0]])
    >>> deform(v, extent=2.0, taper=0.5).tolist()
    [[0.5, -1.0, 0.0], [1.5, 1.0, 0.0]]
    >>> np.round(deform(v, extent=2.0, twist=np.pi), 12).tolist()
    [[0.0, -1.0, 1.0], [0.0, 1.0, -1.0]]
    """
    v = np.array(verts, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"verts must be an (N, 3) array, got shape {v.shape}")
    if not (np.isfinite(extent) and extent > 0):
        raise ValueError(f"extent must be a finite float > 0, got {extent!r}")
    if not -1.0 < taper < 1.0:
        raise ValueError(f"taper must lie in (-1, 1), got {taper!r}")
    t = v[:, 1] / (extent / 2)
    if taper:
        k = 1.0 + taper * t
        v[:, 0] *= k
        v[:, 2] *= k
    if twist:
        a = twist * t / 2
        c, s = np.cos(a), np.sin(a)
        x, z = v[:, 0].copy(), v[:, 2]
        v[:, 0] = c * x + s * z
        v[:, 2] = c * z - s * x
    if bend:
        theta = bend * v[:, 1] / extent  # = arc length y times the curvature bend / extent
        x, y = v[:, 0].copy(), v[:, 1].copy()
        # R (1 - cos theta) and R sin theta with R = extent / bend, in forms exact at theta -> 0
        v[:, 0] = y * np.sin(theta / 2) * np.sinc(theta / (2 * np.pi)) + x * np.cos(theta)
        v[:, 1] = y * np.sinc(theta / np.pi) - x * np.sin(theta)
    return v


def subdivide(verts: np.ndarray, faces: np.ndarray, coords: np.ndarray, *, max_edge: float,
              max_levels: int = 6, max_faces: int = 200_000
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split triangles until every edge is shorter than ``max_edge``, without cracks.

    Each round splits every edge of length ``>= max_edge`` at its midpoint (one new vertex per
    edge, shared by both of its faces; coords interpolated linearly) and each face into 2, 3 or
    4 triangles (4: the 1-to-4 midpoint split), keeping its winding. Faces that share an edge
    only through duplicated vertices of the same position (texture seams, flat shading) split it
    the same way, so a watertight mesh stays watertight; planar faces keep their area. At most
    ``max_levels`` rounds, and a round that would exceed ``max_faces`` faces is not made: then
    some edges stay longer than ``max_edge``.

    Parameters
    ----------
    verts : (N, 3) float64 array
    faces : (M, 3) int64 array
    coords : (N, 2) float64 array
    max_edge : float
        Edge length bound (> 0), in the units of ``verts``.
    max_levels, max_faces : int
        Caps on the rounds and on the faces.

    Returns
    -------
    verts, faces, coords : (N', 3) float64, (M', 3) int64, (N', 2) float64 arrays
        The input vertices come first, unchanged.

    Examples
    --------
    >>> v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    >>> f, uv = np.array([[0, 1, 2]]), v[:, :2].copy()
    >>> v2, f2, uv2 = subdivide(v, f, uv, max_edge=0.5)
    >>> len(v2), len(f2), float(np.linalg.norm(v2[f2] - v2[np.roll(f2, 1, 1)], axis=2).max())
    (15, 16, 0.3535533905932738)
    """
    verts = np.asarray(verts, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    coords = np.asarray(coords, dtype=np.float64)
    if verts.ndim != 2 or verts.shape[1] != 3:
        raise ValueError(f"verts must be an (N, 3) array, got shape {verts.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"faces must be an (M, 3) array, got shape {faces.shape}")
    if coords.shape != (len(verts), 2):
        raise ValueError(f"coords must be an ({len(verts)}, 2) array, got shape {coords.shape}")
    if faces.size and (faces.min() < 0 or faces.max() >= len(verts)):
        raise ValueError(f"faces index vertices 0..{len(verts) - 1}, got "
                         f"{faces.min()}..{faces.max()}")
    if not (np.isfinite(max_edge) and max_edge > 0):
        raise ValueError(f"max_edge must be a finite float > 0, got {max_edge!r}")
    for _ in range(max_levels):
        edge = verts[np.roll(faces, -1, axis=1)] - verts[faces]
        split = np.einsum("ijk,ijk->ij", edge, edge) >= max_edge * max_edge
        n_split = int(split.sum())
        if not n_split or len(faces) + n_split > max_faces:
            break
        verts, faces, coords = split_edges(verts, faces, coords, split)
    return verts, faces, coords
