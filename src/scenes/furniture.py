"""Seeded furniture: tables, chairs, shelves, stools and lamps assembled from boxes and
cylinders.

Each piece fills the box ``|x| <= sx/2, |y| <= sy/2, |z| <= sz/2`` of its size: it stands on
``y = +sy/2`` (the ground, down is ``+y``) and its highest part reaches ``y = -sy/2``. Parts are
closed and may touch or overlap (a union of closed parts, fine for rasterised ground truth).
Every part's chart starts at the atlas origin: parts repeat one texture patch, as the bars of a
fence do.
"""

from __future__ import annotations

import math

import numpy as np

from scenes._meshkit import LocalMesh, Part, box, cylinder, merge

__all__ = ["furniture", "FURNITURE"]

#: The pieces of :func:`furniture`, in the order the seed picks them.
FURNITURE = ("table", "chair", "shelf", "stool", "lamp")


def _legs(xs: list[float], zs: list[float], top: float,
          bottom: float, thick: float, sides: int, round_legs: bool) -> list[Part]:
    """Vertical legs (boxes or cylinders) at every (x, z) between heights top < bottom."""
    h, cy = bottom - top, (top + bottom) / 2
    if round_legs:
        return [cylinder(thick / 2, h, sides, (x, cy, z)) for x in xs for z in zs]
    return [box((thick, h, thick), (x, cy, z)) for x in xs for z in zs]


def _table(rng: np.random.Generator, sx: float, sy: float, sz: float, sides: int) -> list[Part]:
    top_t = rng.uniform(0.04, 0.08) * sy
    leg = rng.uniform(0.04, 0.08) * min(sx, sz)
    inset = rng.uniform(0.0, 0.08) * min(sx, sz)
    ax, az = sx / 2 - inset - leg / 2, sz / 2 - inset - leg / 2
    parts = [box((sx, top_t, sz), (0.0, -sy / 2 + top_t / 2, 0.0))]
    parts += _legs([-ax, ax], [-az, az], -sy / 2 + top_t, sy / 2, leg, sides,
                   rng.random() < 0.5)
    if rng.random() < 0.5:  # apron under the top
        ah, at = rng.uniform(0.08, 0.15) * sy, leg / 2
        y = -sy / 2 + top_t + ah / 2
        parts += [box((2 * ax, ah, at), (0.0, y, s * az)) for s in (-1, 1)]
        parts += [box((at, ah, 2 * az), (s * ax, y, 0.0)) for s in (-1, 1)]
    return parts


def _chair(rng: np.random.Generator, sx: float, sy: float, sz: float, sides: int) -> list[Part]:
    seat_y = sy / 2 - rng.uniform(0.4, 0.55) * sy  # top of the seat
    seat_t = rng.uniform(0.04, 0.07) * sy
    leg = rng.uniform(0.05, 0.09) * min(sx, sz)
    ax, az = sx / 2 - leg / 2, sz / 2 - leg / 2
    round_legs = rng.random() < 0.4
    parts = [box((sx, seat_t, sz), (0.0, seat_y + seat_t / 2, 0.0))]
    parts += _legs([-ax, ax], [-az], seat_y + seat_t, sy / 2, leg, sides, round_legs)
    parts += _legs([-ax, ax], [az], -sy / 2, sy / 2, leg, sides, round_legs)  # back posts
    back_h = rng.uniform(0.3, 0.6) * (seat_y + sy / 2)
    back_t = 0.6 * leg
    if rng.random() < 0.5:
        parts.append(box((2 * ax, back_h, back_t), (0.0, -sy / 2 + back_h / 2, az)))
    else:  # slats from the seat to a top rail
        rail = 0.25 * back_h
        parts.append(box((2 * ax, rail, back_t), (0.0, -sy / 2 + rail / 2, az)))
        n = int(rng.integers(2, 5))
        span = seat_y - (-sy / 2 + rail)
        for x in np.linspace(-ax, ax, n + 2)[1:-1]:
            parts.append(box((leg * 0.6, span, back_t), (float(x), seat_y - span / 2, az)))
    return parts


def _shelf(rng: np.random.Generator, sx: float, sy: float, sz: float, sides: int) -> list[Part]:
    side_t = rng.uniform(0.02, 0.05) * sx
    board_t = rng.uniform(0.015, 0.04) * sy
    plinth = rng.uniform(0.0, 0.08) * sy
    parts = [box((side_t, sy, sz), (s * (sx / 2 - side_t / 2), 0.0, 0.0)) for s in (-1, 1)]
    n = int(rng.integers(2, 6))
    depth = rng.uniform(0.85, 1.0) * sz
    for y in np.linspace(sy / 2 - plinth - board_t / 2, -sy / 2 + board_t / 2, n):
        parts.append(box((sx - 2 * side_t, board_t, depth), (0.0, float(y), (sz - depth) / 2)))
    if rng.random() < 0.5:  # back panel
        bt = 0.02 * sz
        parts.append(box((sx - 2 * side_t, sy - plinth, bt), (0.0, -plinth / 2, sz / 2 - bt / 2)))
    return parts


def _stool(rng: np.random.Generator, sx: float, sy: float, sz: float, sides: int) -> list[Part]:
    seat_t = rng.uniform(0.05, 0.1) * sy
    m = min(sx, sz)
    leg_r = rng.uniform(0.03, 0.06) * m
    top, ground = -sy / 2 + seat_t, sy / 2
    if rng.random() < 0.5:  # round seat, three or four round legs on a circle
        parts = [cylinder(m / 2, seat_t, 2 * sides, (0.0, -sy / 2 + seat_t / 2, 0.0))]
        n = int(rng.integers(3, 5))
        ring = m / 2 - leg_r - rng.uniform(0.0, 0.1) * m
        a = 2 * math.pi * np.arange(n) / n + rng.uniform(0.0, 2 * math.pi)
        for x, z in zip(ring * np.cos(a), ring * np.sin(a)):
            parts.append(cylinder(leg_r, ground - top, sides, (float(x), (top + ground) / 2,
                                                              float(z))))
        return parts
    parts = [box((sx, seat_t, sz), (0.0, -sy / 2 + seat_t / 2, 0.0))]
    ax, az = sx / 2 - leg_r, sz / 2 - leg_r
    parts += _legs([-ax, ax], [-az, az], top, ground, 2 * leg_r, sides, False)
    y = ground - rng.uniform(0.2, 0.4) * (ground - top)  # rungs
    parts += [box((2 * ax, leg_r, leg_r), (0.0, y, s * az)) for s in (-1, 1)]
    parts += [box((leg_r, leg_r, 2 * az), (s * ax, y, 0.0)) for s in (-1, 1)]
    return parts


def _lamp(rng: np.random.Generator, sx: float, sy: float, sz: float, sides: int) -> list[Part]:
    m = min(sx, sz)
    base_r, base_h = rng.uniform(0.3, 0.45) * m, rng.uniform(0.03, 0.06) * sy
    pole_r = rng.uniform(0.02, 0.04) * m
    shade_h = rng.uniform(0.2, 0.35) * sy
    top_r = rng.uniform(0.5, 0.8) * m / 2
    pole_top = -sy / 2 + 0.5 * shade_h
    return [cylinder(base_r, base_h, 2 * sides, (0.0, sy / 2 - base_h / 2, 0.0)),
            cylinder(pole_r, sy / 2 - pole_top, sides, (0.0, (pole_top + sy / 2) / 2, 0.0)),
            cylinder(m / 2, shade_h, 2 * sides, (0.0, -sy / 2 + shade_h / 2, 0.0), top=top_r)]


_PIECES = {"table": _table, "chair": _chair, "shelf": _shelf, "stool": _stool, "lamp": _lamp}


def furniture(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """A seeded piece of furniture: ``size = (sx, sy, sz)``.

    The seed picks one of :data:`FURNITURE` and its proportions: a table (top, four legs, an
    optional apron), a chair (seat, legs, back posts with a panel or slats, the back at ``+z``),
    a shelf (two sides, 2-5 boards, an optional back panel), a stool (round seat on 3-4 legs, or
    square with rungs) or a lamp (base, pole, shade). Vertices lie in ``|x| <= sx/2``,
    ``|y| <= sy/2``, ``|z| <= sz/2``; feet on ``y = +sy/2``, top at ``y = -sy/2``; tables,
    chairs, shelves and square stools span the box, round stools and lamps ``min(sx, sz)``
    across. Legs and poles have ``max(3, segments // 4)`` sides, round seats, lamp bases and
    shades twice that. Each part is closed; the parts share one chart origin.

    Examples
    --------
    >>> m = furniture((1.2, 0.75, 0.8), 16, 11)  # a table
    >>> np.ptp(m.verts, axis=0).round(12).tolist()
    [1.2, 0.75, 0.8]
    """
    sx, sy, sz = size
    rng = np.random.default_rng(seed)
    kind = FURNITURE[rng.integers(len(FURNITURE))]
    parts = _PIECES[kind](rng, sx, sy, sz, max(3, segments // 4))
    verts, faces, coords = merge(parts, [(0.0, 0.0)] * len(parts))
    extent = (max(p.extent[0] for p in parts), max(p.extent[1] for p in parts))
    return LocalMesh(verts, faces, coords, (float(extent[0]), float(extent[1])))
