"""Seeded trees and bushes: branching skeletons of tapered tubes with flat leaves.

A plant grows in its own unit frame (the ground point at the origin, up = ``-y``): each branch
level is drawn at once (vectorised), children start along their parent and turn away from it;
then the skeleton is scaled into the ``width x height x width`` box, tubes and leaves are built
at their final size in metres, and a last scale about the ground point makes sure every vertex
is inside the box. Branches are closed tapered tubes (flat caps); leaves are diamond-shaped quads
(two triangles, four own vertices each), open surfaces: render plants double-sided.
"""

from __future__ import annotations

import math

import numpy as np

from scenes._meshkit import LocalMesh, Part, atlas_row, cross, frustums, merge, unit

__all__ = ["tree", "bush"]

_UP = np.array([0.0, -1.0, 0.0])


class _Skeleton:
    """Branches of a plant: start and end points (B, 3), base and tip radii (B,) in units of
    the trunk's base radius, and whether each branch bears leaves (the outer two levels)."""

    def __init__(self) -> None:
        self.p0: list[np.ndarray] = []
        self.p1: list[np.ndarray] = []
        self.r0: list[np.ndarray] = []
        self.r1: list[np.ndarray] = []
        self.tip: list[np.ndarray] = []

    def add(self, p0: np.ndarray, p1: np.ndarray, r0: np.ndarray, r1: np.ndarray,
            leafy: bool) -> None:
        self.p0.append(p0)
        self.p1.append(p1)
        self.r0.append(r0)
        self.r1.append(r1)
        self.tip.append(np.full(len(p0), leafy))

    def arrays(self) -> tuple[np.ndarray, ...]:
        return tuple(np.concatenate(a) for a in (self.p0, self.p1, self.r0, self.r1, self.tip))


def _turn(d: np.ndarray, angle: np.ndarray, azimuth: np.ndarray, lift: float) -> np.ndarray:
    """Directions (B, 3) turned by ``angle`` from ``d`` toward ``azimuth``, then kept rising
    (``-y`` component at least ``lift``)."""
    ref = np.where((np.abs(d[:, 0]) < 0.9)[:, None], [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    e1 = unit(cross(d, ref))
    e2 = cross(d, e1)
    out = (np.cos(angle)[:, None] * d + np.sin(angle)[:, None]
           * (np.cos(azimuth)[:, None] * e1 + np.sin(azimuth)[:, None] * e2))
    out[:, 1] = np.minimum(out[:, 1], -lift * np.linalg.norm(out[:, [0, 2]], axis=1) - 1e-3)
    return unit(out)


def _grow(rng: np.random.Generator, p0: np.ndarray, d: np.ndarray, length: np.ndarray,
          r0: np.ndarray, levels: int, children: tuple[int, int], spread: tuple[float, float],
          ) -> _Skeleton:
    """Grow ``levels`` levels of branches from the first ones (p0, d, length, r0)."""
    sk = _Skeleton()
    for level in range(levels):
        last = level == levels - 1
        r1 = r0 * (0.35 if last else 0.7)
        p1 = p0 + d * length[:, None]
        sk.add(p0, p1, r0, r1, level >= levels - 2)
        if last:
            break
        count = rng.integers(children[0], children[1] + 1, len(p0))
        parent = np.repeat(np.arange(len(p0)), count)
        rank = np.arange(len(parent)) - np.repeat(np.cumsum(count) - count, count)
        first = rank == 0  # the leader continues its parent
        n = len(parent)
        f = np.where(first, 1.0, rng.uniform(0.45, 0.95, n))
        angle = np.radians(np.where(first, rng.uniform(5.0, 20.0, n), rng.uniform(*spread, n)))
        azimuth = rng.uniform(0.0, 2 * math.pi, len(p0))[parent] + rank * 2.39996
        base = p0[parent] + f[:, None] * (p1 - p0)[parent]
        rad = r0[parent] + f * (r1 - r0)[parent]
        d = _turn(d[parent], angle, azimuth, 0.15)
        length = length[parent] * np.where(first, rng.uniform(0.6, 0.8, n),
                                           rng.uniform(0.6, 0.85, n))
        p0, r0 = base, rad * np.where(first, 1.0, rng.uniform(0.55, 0.75, n))
    return sk


def _leaves(rng: np.random.Generator, p0: np.ndarray, p1: np.ndarray, count: int, size: float
            ) -> Part:
    """``count`` diamond leaves along the given branches (B, 3), each of its own four vertices;
    all share one chart (width x length of the largest leaf)."""
    pick = rng.integers(0, len(p0), count)
    f = rng.uniform(0.3, 1.0, count)[:, None]
    scale = size * rng.uniform(0.7, 1.3, count)
    anchor = p0[pick] + f * (p1 - p0)[pick] + unit(rng.standard_normal((count, 3))) * (
        0.4 * scale * rng.random(count))[:, None]
    along = unit(unit(p1 - p0)[pick] + 0.9 * unit(rng.standard_normal((count, 3))))
    side = unit(cross(along, unit(rng.standard_normal((count, 3)))))
    ratio = rng.uniform(0.35, 0.6, count)
    half_w = (0.5 * ratio * scale)[:, None]
    tip = along * scale[:, None]
    verts = np.stack([anchor, anchor + tip / 2 + side * half_w, anchor + tip,
                      anchor + tip / 2 - side * half_w], 1).reshape(-1, 3)
    faces = (np.array([[0, 1, 2], [0, 2, 3]])[None] + 4 * np.arange(count)[:, None, None])
    wmax, lmax = float((ratio * scale).max()), float(scale.max())
    hw, ln = half_w[:, 0], scale
    coords = np.stack([np.stack([np.full(count, wmax / 2), wmax / 2 + hw, np.full(count, wmax / 2),
                                 wmax / 2 - hw], 1),
                       np.stack([np.zeros(count), ln / 2, ln, ln / 2], 1)], -1).reshape(-1, 2)
    return Part(verts, faces.reshape(-1, 3), coords, (wmax, lmax))


def _plant(rng: np.random.Generator, sk: _Skeleton, width: float, height: float,
           trunk_radius: float, leaf_count: int, leaf_size: float, sides: int) -> LocalMesh:
    """Fit a unit-frame skeleton into the box, build its tubes and leaves, and clamp."""
    p0, p1, r0, r1, tip = sk.arrays()
    pts = np.concatenate([p0, p1])
    margin = leaf_size + trunk_radius
    across = max(width / 2 - margin, 0.3 * width / 2) / max(float(np.abs(pts[:, [0, 2]]).max()),
                                                            1e-9)
    up = max(height - margin, 0.3 * height) / max(float(-pts[:, 1].min()), 1e-9)
    scale = np.array([across, up, across])
    p0, p1 = p0 * scale, p1 * scale
    side, caps = frustums(p0, p1, r0 * trunk_radius, r1 * trunk_radius, sides)
    branches = Part(*merge([side, caps], [(0.0, 0.0), (side.extent[0] * 1.02, 0.0)]),
                    (side.extent[0] * 1.02 + caps.extent[0], max(side.extent[1], caps.extent[1])))
    leaves = _leaves(rng, p0[tip], p1[tip], leaf_count, leaf_size)
    mesh = atlas_row([branches, leaves])
    verts = mesh.verts
    # last guard: scale about the ground point so that every vertex is inside the box
    shrink_xz = min(1.0, width / 2 / max(float(np.abs(verts[:, [0, 2]]).max()), 1e-12))
    shrink_y = min(1.0, height / max(float(-verts[:, 1].min()), 1e-12))
    verts = verts * np.array([shrink_xz, shrink_y, shrink_xz])
    verts[:, 1] = np.minimum(verts[:, 1] + height / 2, height / 2)
    return LocalMesh(verts, mesh.faces, mesh.coords, mesh.extent)


def tree(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """A seeded tree: ``size = (width, height)``.

    A vertical trunk from the ground point ``(0, height/2, 0)`` (down is ``+y``) upward, 3-4
    levels of branches (3-5 children per branch with three levels, 2-4 with four; a leader
    continues each branch, the others leave it at 35-75 degrees), radii tapering by level, then
    ``24 * segments`` leaves on the outer two levels. Vertices lie in ``|x|, |z| <=
    width/2``, ``|y| <= height/2``; the trunk's base sits on ``y = height/2``. Branch tubes have
    ``max(3, segments // 10)`` sides. Open (leaves): render double-sided.

    Examples
    --------
    >>> m = tree((2.0, 3.0), 16, 0)
    >>> float(m.verts[:, 1].max()), bool(np.abs(m.verts[:, [0, 2]]).max() <= 1.0)
    (1.5, True)
    """
    width, height = size
    rng = np.random.default_rng(seed)
    levels = int(rng.integers(3, 5))
    children = (2, 4) if levels == 4 else (3, 5)
    sk = _grow(rng, np.zeros((1, 3)), _UP[None], np.array([rng.uniform(0.3, 0.45)]),
               np.ones(1), levels, children, (35.0, 75.0))
    trunk = min(rng.uniform(0.015, 0.03) * height, 0.06 * width)
    leaf = min(rng.uniform(0.04, 0.06) * (width + height) / 2, 0.1 * min(width, height))
    return _plant(rng, sk, width, height, trunk, 24 * segments, leaf, max(3, segments // 10))


def bush(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """A seeded bush: ``size = (width, height)``.

    5-11 stems from near the ground point ``(0, height/2, 0)`` leaning 10-60 degrees outward,
    each branching twice more (2-3 children), then ``24 * segments`` dense leaves on the
    outer two levels. Vertices lie in ``|x|, |z| <= width/2``, ``|y| <= height/2`` (ground at
    ``+height/2``). Tubes have ``max(3, segments // 10)`` sides. Open (leaves): render
    double-sided.

    Examples
    --------
    >>> m = bush((1.0, 0.6), 16, 0)
    >>> bool(m.verts[:, 1].max() <= 0.3), bool(np.abs(m.verts[:, [0, 2]]).max() <= 0.5)
    (True, True)
    """
    width, height = size
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 12))
    radius = min(rng.uniform(0.01, 0.02) * height, 0.03 * width)
    base = np.column_stack([rng.uniform(-0.05, 0.05, (n, 1)), np.full((n, 1), -0.05),
                            rng.uniform(-0.05, 0.05, (n, 1))])
    d = _turn(np.repeat(_UP[None], n, 0), np.radians(rng.uniform(10.0, 60.0, n)),
              2 * math.pi * (np.arange(n) + rng.uniform(-0.3, 0.3, n)) / n, 0.1)
    sk = _grow(rng, base, d, rng.uniform(0.45, 0.8, n), rng.uniform(0.7, 1.0, n), 3, (2, 3),
               (25.0, 55.0))
    leaf = min(rng.uniform(0.04, 0.07) * (width + height) / 2, 0.12 * min(width, height))
    return _plant(rng, sk, width, height, radius, 24 * segments, leaf, max(3, segments // 10))
