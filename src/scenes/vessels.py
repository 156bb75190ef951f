"""Seeded lathed vessels: vases, bottles, bowls, lampshades and goblets.

A vessel is a profile in the (rho, y) half plane revolved about local ``y``
(:func:`scenes._meshkit.revolve`). Hollow vessels have a wall of seeded thickness, so every
vessel is a closed solid (watertight, wound outward) whose cavity opens at the top; the
lampshade is a thin ring-shaped wall open at both ends. The same ``(size, segments, seed)``
gives the same bits; randomness comes only from ``np.random.default_rng(seed)``.
"""

from __future__ import annotations

import math

import numpy as np

from scenes._meshkit import LocalMesh, revolve

__all__ = ["revolution", "VESSELS"]

#: The vessel types of :func:`revolution`, in the order the seed picks them.
VESSELS = ("vase", "bottle", "bowl", "lampshade", "goblet")


def _smooth(t: np.ndarray, knots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """C1 interpolation of ``values`` at increasing ``knots`` (smoothstep between knots)."""
    i = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(knots) - 2)
    s = np.clip((t - knots[i]) / (knots[i + 1] - knots[i]), 0.0, 1.0)
    s = s * s * (3 - 2 * s)
    return values[i] + (values[i + 1] - values[i]) * s


def _vessel(kind: str, rng: np.random.Generator, radius: float, height: float, n: int
            ) -> list[np.ndarray]:
    """Profile pieces (rho, y) of a vessel: bottom at ``y = height/2``, top at ``-height/2``,
    widest point exactly ``radius``; hollow ones have a wall, so all are closed solids."""
    t = np.linspace(0.0, 1.0, n + 1)
    h2 = height / 2

    def y(tt: np.ndarray | float) -> np.ndarray:
        return h2 - height * np.asarray(tt)

    def seg(a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
        return np.array([a, b], float)

    def path(rho: np.ndarray, tt: np.ndarray) -> np.ndarray:
        return np.stack([rho, y(tt)], 1)

    wall = rng.uniform(0.04, 0.08) * radius
    if kind == "lampshade":
        wall = rng.uniform(0.015, 0.03) * radius
        rho = 1.0 + (rng.uniform(0.4, 0.8) - 1.0) * t + rng.uniform(-0.1, 0.1) * np.sin(math.pi * t)
        rho = radius * rho / rho.max()
        return [path(rho, t), seg((rho[-1], -h2), (rho[-1] - wall, -h2)),
                path(rho[::-1] - wall, t[::-1]), seg((rho[0] - wall, h2), (rho[0], h2))]
    if kind == "bottle":
        tb, tn = rng.uniform(0.4, 0.6), rng.uniform(0.75, 0.88)
        neck = rng.uniform(0.2, 0.35)
        rho = radius * _smooth(t, np.array([0.0, tb, tn, 1.0]), np.array([1.0, 1.0, neck, neck]))
        return [seg((0.0, h2), (radius, h2)), path(rho, t), seg((rho[-1], -h2), (0.0, -h2))]
    if kind == "vase":
        knots = np.linspace(0.0, 1.0, 5)
        vals = np.array([rng.uniform(lo, hi) for lo, hi in
                         ((0.45, 0.7), (0.75, 1.0), (0.6, 1.0), (0.3, 0.5), (0.4, 0.7))])
        outer, floor = _smooth(t, knots, vals), rng.uniform(0.05, 0.1)
        outer = radius * outer / outer.max()
        pieces = [seg((0.0, h2), (outer[0], h2)), path(outer, t)]
    elif kind == "bowl":
        foot, floor = rng.uniform(0.35, 0.55), rng.uniform(0.08, 0.15)
        outer = radius * (foot + (1 - foot) * np.sin(math.pi / 2 * t) ** rng.uniform(0.5, 0.9))
        pieces = [seg((0.0, h2), (outer[0], h2)), path(outer, t)]
    else:  # goblet: foot disc, stem, cup
        foot, stem = rng.uniform(0.6, 0.9) * radius, rng.uniform(0.06, 0.12) * radius
        ft, tc = rng.uniform(0.03, 0.05), rng.uniform(0.35, 0.55)
        t = np.linspace(tc, 1.0, n + 1)
        outer = stem + (radius - stem) * ((t - tc) / (1 - tc)) ** rng.uniform(0.4, 0.7)
        floor = tc + (1 - tc) * 0.15
        neck = ft + 0.04  # the foot's top slopes into the stem
        pieces = [seg((0.0, h2), (foot, h2)), seg((foot, h2), (foot, y(ft))),
                  seg((foot, y(ft)), (stem, y(neck))), seg((stem, y(neck)), (stem, y(tc))),
                  path(outer, t)]
    inner_t = np.linspace(1.0, floor, n + 1)
    inner = np.interp(inner_t, t, outer) - wall
    return [*pieces, seg((outer[-1], -h2), (outer[-1] - wall, -h2)), path(inner, inner_t),
            seg((inner[-1], float(y(floor))), (0.0, float(y(floor))))]


def revolution(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """Lathed vessel about local ``y``: ``size = (radius, height)``.

    The seed picks one of :data:`VESSELS` and its profile. Vase, bowl and goblet are hollow with
    a wall (the cavity open at the top), the lampshade is a thin ring-shaped wall open at both
    ends, the bottle is solid; all are closed solids (no open surface). Vertices lie in the
    cylinder ``x^2 + z^2 <= radius^2``, ``|y| <= height/2``; the bottom is at ``+height/2``
    (down), the rim at ``-height/2``, and the widest ring has exactly ``radius``. ``segments``
    around, ``max(3, segments // 4)`` rows per curved profile piece. Coords: (``radius *
    angle``, arc length along the profile).

    Examples
    --------
    >>> m = revolution((0.2, 0.5), 16, 1)
    >>> float(np.ptp(m.verts[:, 1])), round(float(np.hypot(m.verts[:, 0], m.verts[:, 2]).max()), 12)
    (0.5, 0.2)
    """
    radius, height = size
    rng = np.random.default_rng(seed)
    kind = VESSELS[rng.integers(len(VESSELS))]
    part = revolve(_vessel(kind, rng, radius, height, max(3, segments // 4)), segments, radius)
    return LocalMesh(*part)
