"""Seeded extrusions: a star polygon, a smooth blob or an L, T or U letter, extruded along
local ``z``.

The outline lies in the local x-y plane, counter-clockwise; the side walls and the two caps make
a closed solid wound outward. The same ``(size, segments, seed)`` gives the same bits;
randomness comes only from ``np.random.default_rng(seed)``.
"""

from __future__ import annotations

import math

import numpy as np

from scenes._meshkit import LocalMesh, Part, atlas_row, grid_faces

__all__ = ["extrusion"]


def _ear_clip(poly: np.ndarray) -> np.ndarray:
    """Triangles (counter-clockwise) of a small simple counter-clockwise polygon."""
    idx, tris = list(range(len(poly))), []
    while len(idx) > 3:
        for k in range(len(idx)):
            a, b, c = idx[k - 1], idx[k], idx[(k + 1) % len(idx)]
            ab, ac = poly[b] - poly[a], poly[c] - poly[a]
            if ab[0] * ac[1] - ab[1] * ac[0] <= 1e-12:
                continue  # reflex or flat corner
            others = [poly[j] for j in idx if j not in (a, b, c)]
            if not any(_inside(p, poly[a], poly[b], poly[c]) for p in others):
                tris.append((a, b, c))
                idx.pop(k)
                break
        else:  # no ear: the outline crosses itself (a simple polygon always has two)
            raise ValueError(f"extrusion outline is not a simple polygon: {poly.tolist()}")
    tris.append(tuple(idx))
    return np.array(tris, np.int64)


def _inside(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> bool:
    d = [(q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
         for q, r in ((a, b), (b, c), (c, a))]
    return min(d) >= -1e-12


def _letter(rng: np.random.Generator) -> np.ndarray:
    """An L, T or U outline (counter-clockwise, y up in the drawing) with seeded bar widths."""
    a, w, h = rng.uniform(0.25, 0.45), rng.uniform(0.8, 1.2), 1.0
    shape = ("L", "T", "U")[rng.integers(3)]
    if shape == "L":
        pts = [(0, 0), (w, 0), (w, a), (a, a), (a, h), (0, h)]
    elif shape == "T":
        c0, c1 = w / 2 - a / 2, w / 2 + a / 2
        pts = [(c0, 0), (c1, 0), (c1, h - a), (w, h - a), (w, h), (0, h), (0, h - a), (c0, h - a)]
    else:
        if w - a <= a:  # the two bars would overlap (the outline crossing itself): thinner bars
            a = 0.4 * w
        pts = [(0, 0), (w, 0), (w, h), (w - a, h), (w - a, a), (a, a), (a, h), (0, h)]
    poly = np.array(pts, float)
    return poly - (poly.min(axis=0) + poly.max(axis=0)) / 2


def extrusion(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """A seeded outline in the local x-y plane extruded along ``z``: ``size = (radius, depth)``.

    The seed picks a star polygon (5-12 corners at jittered angles, radii in [0.4, 1]), a smooth
    blob (``segments`` points, a random periodic radius in [0.4, 1]) or an L, T or U letter;
    the outline is scaled so its farthest corner is at ``radius``. Vertices lie in
    ``x^2 + y^2 <= radius^2``, ``|z| <= depth/2``. Polygon sides get their own vertices (sharp
    edges); the blob's side is smooth. Caps: a fan from the centre (star-shaped outlines) or
    ear clipping (letters). Coords: side (arc along the outline, z + depth/2), caps (x, y) + r.

    Examples
    --------
    >>> m = extrusion((0.3, 0.1), 16, 2)
    >>> float(np.ptp(m.verts[:, 2])), bool(np.hypot(*m.verts[:, :2].T).max() <= 0.3 + 1e-12)
    (0.1, True)
    """
    radius, depth = size
    rng = np.random.default_rng(seed)
    style = rng.choice(3, p=[0.45, 0.3, 0.25])
    if style == 2:
        poly = _letter(rng)
    else:
        k = int(rng.integers(5, 13)) if style == 0 else max(8, segments)
        ang = 2 * math.pi * (np.arange(k) + (rng.uniform(-0.35, 0.35, k) if style == 0 else 0.0)
                             ) / k + rng.uniform(0.0, 2 * math.pi)
        if style == 0:
            rad = rng.uniform(0.4, 1.0, k)
        else:
            j = np.arange(1, 5)[:, None]
            c = rng.standard_normal((2, 4, 1)) * 0.3 / j
            e = (c[0] * np.cos(j * ang) + c[1] * np.sin(j * ang)).sum(axis=0)
            rad = 0.4 + 0.6 * (e - e.min()) / max(float(np.ptp(e)), 1e-12)
        poly = np.stack([rad * np.cos(ang), rad * np.sin(ang)], 1)
    poly = poly * (radius / np.hypot(poly[:, 0], poly[:, 1]).max())
    x, y = poly[:, 0], poly[:, 1]
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:
        poly = poly[::-1]
    n, hd = len(poly), depth / 2
    nxt = np.roll(poly, -1, axis=0)
    edge = np.linalg.norm(nxt - poly, axis=1)
    s = np.concatenate([[0.0], np.cumsum(edge)])
    if style == 1:  # smooth side: one grid, the seam column repeated
        ring = np.concatenate([poly, poly[:1]])
        sv = np.concatenate([np.column_stack([ring, np.full(n + 1, -hd)]),
                             np.column_stack([ring, np.full(n + 1, hd)])])
        sf = grid_faces(1, n)[:, [0, 2, 1]]
        suv = np.column_stack([np.tile(s, 2), np.repeat([0.0, depth], n + 1)])
    else:  # one quad per edge: p_i, p_i+1 at -d/2, then at +d/2
        quad = np.stack([poly, nxt, nxt, poly], 1)
        zq = np.array([-hd, -hd, hd, hd])
        sv = np.concatenate([quad, np.broadcast_to(zq[None, :, None], (n, 4, 1))], 2)
        sv = sv.reshape(-1, 3)
        sf = (np.array([[0, 1, 2], [0, 2, 3]])[None] + 4 * np.arange(n)[:, None, None])
        sf = sf.reshape(-1, 3)
        su = np.stack([s[:-1], s[1:], s[1:], s[:-1]], 1)
        suv = np.stack([su, np.broadcast_to(zq + hd, (n, 4))], -1).reshape(-1, 2)
    side = Part(sv, sf, suv, (float(s[-1]), depth))
    if style == 2:
        tri, flat = _ear_clip(poly), poly
    else:
        j = np.arange(n)
        tri = np.stack([np.zeros(n, np.int64), 1 + j, 1 + (j + 1) % n], 1)
        flat = np.concatenate([[[0.0, 0.0]], poly])
    m = len(flat)
    cv = np.concatenate([np.column_stack([flat, np.full(m, hd)]),
                         np.column_stack([flat, np.full(m, -hd)])])
    cf = np.concatenate([tri, tri[:, [0, 2, 1]] + m])
    caps = Part(cv, cf, cv[:, :2] + radius, (2 * radius, 2 * radius))
    return atlas_row([side, caps])
