"""Seeded closed solids of the object families: superquadrics, rocks, tori, knots, polyhedra
and wires (lathed vessels are :mod:`scenes.vessels`, extrusions :mod:`scenes.extrusions`).

Each builder is ``builder(size, segments, seed) -> LocalMesh`` (the ``_Local`` tuple of
:mod:`scenes.primitives`): local vertices centred on the origin in the camera-like object frame
(``y`` down, so "up" is ``-y``), faces wound counter-clockwise seen from outside, coords in metres.
Every mesh is closed: watertight once the texture-seam duplicates are merged, of positive
volume. Randomness comes only from ``np.random.default_rng(seed)``; the same arguments give the
same bits. The builders trust their input (:func:`scenes.families.family_size_problem` states the
size conditions, which the spec checks).
"""

from __future__ import annotations

import math
from functools import lru_cache
from itertools import combinations

import numpy as np
import trimesh

from scenes._meshkit import (
    LocalMesh,
    atlas_row,
    cross,
    grid_faces,
    split_edges,
    tube,
    unit,
)

__all__ = ["superquadric", "rock", "torus", "knot", "polyhedron", "wire", "KNOTS",
           "KNOT_TUBE_RATIO", "WIRE_THICKNESS_RATIO"]

#: (p, q) torus knots of :func:`knot`, each with the range its ratio (torus tube circle / ring
#: radius) is drawn from: ratios where the centre line's reach (its nearest non-neighbouring
#: strands and its tightest curvature, measured) allows a tube of at least 0.16 ``radius``.
KNOTS: dict[tuple[int, int], tuple[float, float]] = {
    (2, 3): (0.28, 0.60), (2, 5): (0.28, 0.46), (3, 4): (0.32, 0.52), (3, 5): (0.36, 0.44),
    (2, 7): (0.26, 0.32)}
#: Largest ``tube / radius`` of a knot: its tube never meets itself (see KNOTS).
KNOT_TUBE_RATIO = 0.15
#: Largest ``thickness / length`` of a wire (its centre line bends no tighter than 0.2 length).
WIRE_THICKNESS_RATIO = 0.25


def _snap(a: np.ndarray) -> np.ndarray:
    """Zero the rounding residue of cos/sin at multiples of pi / 2 (exact extents)."""
    return np.where(np.abs(a) < 1e-12, 0.0, a)


def superquadric(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """Superellipsoid of extents ``size = (sx, sy, sz)``, exponents from the seed.

    ``x = sx/2 c(eta)^e1 c(w)^e2``, ``y = -sy/2 s(eta)^e1``, ``z = sz/2 c(eta)^e1 s(w)^e2``
    (signed powers), ``e1, e2`` log-uniform in [0.25, 2.5]: from box-like to pinched star shapes.
    Vertices lie in ``|x| <= sx/2, |y| <= sy/2, |z| <= sz/2`` and reach all six faces of that box.
    ``segments`` (rounded up to a multiple of 4) meridians, half as many parallels. Coords:
    (arc along the equator, arc along the x-y meridian), like the sphere's.

    Examples
    --------
    >>> m = superquadric((1.0, 2.0, 0.5), 16, 0)
    >>> np.ptp(m.verts, axis=0).tolist(), m.faces.shape
    ([1.0, 2.0, 0.5], (224, 3))
    """
    sx, sy, sz = size
    e1, e2 = np.exp(np.random.default_rng(seed).uniform(math.log(0.25), math.log(2.5), 2))
    n_lon = 4 * max(1, math.ceil(segments / 4))
    n_lat = n_lon // 2
    theta = np.linspace(0.0, math.pi, n_lat + 1)
    omega = np.linspace(0.0, 2 * math.pi, n_lon + 1)

    def spow(a: np.ndarray, e: float) -> np.ndarray:
        return np.sign(a) * np.abs(a) ** e

    st, ct = spow(_snap(np.sin(theta)), e1), spow(_snap(np.cos(theta)), e1)
    cw, sw = spow(_snap(np.cos(omega)), e2), spow(_snap(np.sin(omega)), e2)
    cw[-1], sw[-1] = cw[0], sw[0]
    verts = np.stack([sx / 2 * st[:, None] * cw, np.broadcast_to(-sy / 2 * ct[:, None],
                                                                (n_lat + 1, n_lon + 1)),
                      sz / 2 * st[:, None] * sw], -1).reshape(-1, 3)
    faces = _pole_faces(n_lat, n_lon)
    u = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(sx / 2 * cw), np.diff(sz / 2 * sw)))])
    v = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(sx / 2 * st), np.diff(sy / 2 * ct)))])
    coords = np.stack(np.meshgrid(u, v, indexing="xy"), -1).reshape(-1, 2)
    return LocalMesh(verts, faces, coords, (float(u[-1]), float(v[-1])))


def _pole_faces(n_lat: int, n_lon: int) -> np.ndarray:
    """Lat-long grid faces without the degenerate halves of the cells at the two poles."""
    faces = grid_faces(n_lat, n_lon)
    n_cells = n_lat * n_lon
    row = np.repeat(np.arange(n_lat), n_lon)
    return np.concatenate([faces[:n_cells][row != n_lat - 1], faces[n_cells:][row != 0]])


@lru_cache(maxsize=8)
def _icosphere(level: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere: the icosahedron split 1-to-4 ``level`` times (read-only arrays)."""
    g = (1 + math.sqrt(5)) / 2
    v = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
                  [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]],
                 float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]], np.int64)
    v = unit(v)
    c = np.zeros((len(v), 2))
    for _ in range(level):
        v, f, c = split_edges(v, f, c, np.ones(f.shape, bool))
        v = unit(v)
    v.flags.writeable = False
    f.flags.writeable = False
    return v, f


def _axis_charts(verts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, ...]:
    """Generated coords in metres: each face projected along the axis nearest its normal.

    Unlike :func:`scenes.primitives._triplanar`, faces of one axis share their vertices (smooth
    shading inside a chart); a vertex is repeated only where charts meet.
    """
    tri = verts[faces]
    axis = np.argmax(np.abs(cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])), axis=1)
    key = faces * 3 + axis[:, None]
    used = np.zeros(3 * len(verts), bool)
    used[key] = True
    uniq = np.flatnonzero(used)  # sorted (vertex, axis) pairs, without np.unique's sort
    inverse = (np.cumsum(used) - 1)[key]
    out_v = verts[uniq // 3]
    pick = np.array([[2, 1], [0, 2], [0, 1]])[uniq % 3]  # x: (z, y), y: (x, z), z: (x, y)
    coords = np.take_along_axis(out_v, pick, axis=1)
    coords = coords - coords.min(axis=0)
    return out_v, inverse.astype(np.int64), coords


def rock(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """Rock: an icosphere displaced radially by seeded smooth noise, squashed, scaled.

    The radius is ``1 + A n(d)`` over unit directions ``d``, ``n`` a sum of random plane waves in
    3-D over four octaves (no pole or seam artefacts), normalised to ``max |n| = 1``, ``A`` in
    [0.15, 0.35]; then the axes are scaled by random factors in [0.6, 1] and the whole by the
    factor that puts the farthest vertex at ``size = (radius,)``. Radial displacement and a
    linear map keep it star-shaped, hence free of self-intersections. Vertices lie within
    ``radius`` of the origin, one at ``radius``. ``segments`` sets the icosphere level
    ``ceil(log2(segments / 4))`` in [1, 7] (1280 faces at 32, 5120 at 64). Coords: per-axis
    projection charts (see ``_axis_charts``).

    Examples
    --------
    >>> m = rock((0.5,), 16, 3)
    >>> round(float(np.linalg.norm(m.verts, axis=1).max()), 12), m.faces.shape
    (0.5, (320, 3))
    """
    (radius,) = size
    rng = np.random.default_rng(seed)
    level = int(np.clip(math.ceil(math.log2(max(segments, 1) / 4)), 1, 7))
    sphere, faces = _icosphere(level)
    n_wave = 6
    freq = np.repeat(0.6 * 2.0 ** np.arange(4), n_wave)
    amp = np.repeat(0.55 ** np.arange(4), n_wave)
    direction = unit(rng.standard_normal((4 * n_wave, 3)))
    phase = rng.uniform(0.0, 2 * math.pi, 4 * n_wave)
    noise = np.sin(2 * math.pi * freq * (sphere @ direction.T) + phase) @ amp
    noise /= np.abs(noise).max()
    verts = sphere * (1.0 + rng.uniform(0.15, 0.35) * noise)[:, None]
    verts = verts * rng.uniform(0.6, 1.0, 3)
    verts *= radius / np.sqrt(np.einsum("ij,ij->i", verts, verts)).max()
    v, f, coords = _axis_charts(verts, faces)
    extent = tuple(float(max(e, 1e-9)) for e in coords.max(axis=0))
    return LocalMesh(v, f, coords, extent)


def torus(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """Ring torus in the local x-y plane: ``size = (radius, tube)``, centre-line radius
    ``radius``, tube radius ``tube < radius``. Vertices lie in ``|x|, |y| <= radius + tube``,
    ``|z| <= tube``. ``segments`` around the ring, ``max(3, segments // 2)`` around the tube.
    Coords: (arc along the centre line, arc around the tube). The seed is not used.

    Examples
    --------
    >>> m = torus((1.0, 0.25), 8, 0)
    >>> float(m.verts[:, 0].max()), float(m.verts[:, 2].max()), m.faces.shape
    (1.25, 0.25, (64, 3))
    """
    radius, tb = size
    n, m = segments, max(3, segments // 2)
    phi = np.linspace(0.0, 2 * math.pi, n + 1)
    theta = np.linspace(0.0, 2 * math.pi, m + 1)
    cp, sp = _snap(np.cos(phi)), _snap(np.sin(phi))
    ct, st = _snap(np.cos(theta)), _snap(np.sin(theta))
    cp[-1], sp[-1], ct[-1], st[-1] = 1.0, 0.0, 1.0, 0.0
    rr = radius + tb * ct[None, :]
    verts = np.stack([rr * cp[:, None], rr * sp[:, None],
                      np.broadcast_to(tb * st, (n + 1, m + 1))], -1).reshape(-1, 3)
    coords = np.stack(np.meshgrid(radius * phi, tb * theta, indexing="ij"), -1).reshape(-1, 2)
    return LocalMesh(verts, grid_faces(n, m), coords,
                     (2 * math.pi * radius, 2 * math.pi * tb))


def knot(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """A (p, q) torus knot swept by a circular tube: ``size = (radius, tube)``.

    The seed picks (p, q) from :data:`KNOTS`, the knot's ring / torus-circle ratio in its range
    and the handedness. The centre line winds p times about local ``z`` and q times about a torus
    circle; it is scaled so that its farthest point is ``radius - tube`` from the origin, so every
    vertex lies within ``radius`` (``|z| <= radius`` too). The tube never meets itself while
    ``tube <= KNOT_TUBE_RATIO * radius`` (0.15). Rotation-minimising frames, the holonomy spread
    over the loop so the seam closes. ``segments * (p + q) // 2`` rings of
    ``max(3, segments // 4)`` sides. Coords: (arc length, arc around the tube).

    Examples
    --------
    >>> m = knot((1.0, 0.1), 16, 0)
    >>> bool(np.linalg.norm(m.verts, axis=1).max() <= 1.0), m.faces.shape[1]
    (True, 3)
    """
    radius, tb = size
    rng = np.random.default_rng(seed)
    keys = list(KNOTS)
    p, q = keys[rng.integers(len(keys))]
    k = rng.uniform(*KNOTS[(p, q)])
    hand = 1.0 if rng.random() < 0.5 else -1.0
    scale = radius - tb
    big, small = scale / (1 + k), scale * k / (1 + k)
    n = max(8, segments * (p + q) // 2)
    t = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    rr = big + small * np.cos(q * t)
    line = np.stack([rr * np.cos(p * t), rr * np.sin(p * t), hand * small * np.sin(q * t)], 1)
    (side,) = tube(line, np.full(n, tb), max(3, segments // 4), closed=True,
                   reference=np.array([0.0, 0.0, 1.0]))
    return LocalMesh(*side)


@lru_cache(maxsize=32)
def _triples(n: int) -> np.ndarray:
    return np.array(list(combinations(range(n), 3)), np.int64)


def _hull(points: np.ndarray) -> np.ndarray:
    """Outward triangles of the convex hull of a few points in general position (brute force
    over all triples, checked; trimesh's qhull if the check fails)."""
    tri = _triples(len(points))
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    normal = cross(b - a, c - a)
    side = np.einsum("tj,pj->tp", normal, points) - np.einsum("tj,tj->t", normal, a)[:, None]
    tol = 1e-12 * float(np.abs(points).max()) ** 3
    np.put_along_axis(side, tri, 0.0, axis=1)
    out = (side <= tol).all(axis=1)
    inn = (side >= -tol).all(axis=1)
    faces = np.concatenate([tri[out], tri[inn][:, [0, 2, 1]]])
    n = len(points)
    directed = (faces * n + np.roll(faces, -1, axis=1)).ravel()
    reverse = (np.roll(faces, -1, axis=1) * n + faces).ravel()
    n_vert = len(np.unique(faces))
    closed = len(np.unique(directed)) == len(directed) and np.isin(reverse, directed).all()
    if len(faces) != 2 * n_vert - 4 or not closed:
        return np.asarray(trimesh.convex.convex_hull(points).faces, np.int64)
    return faces


def polyhedron(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """Convex polyhedron: the hull of 4-24 seeded points near the sphere ``size = (radius,)``.

    Points: random directions at distances in [0.85, 1] (redrawn while the hull's volume is
    under 0.1 radius^3), scaled so the farthest is at ``radius``; every vertex lies within
    ``radius``. Flat faces: each triangle has its own corners and coords in its own plane, in
    metres (no stretch); all face charts overlap in one patch. ``segments`` is not used.

    Examples
    --------
    >>> m = polyhedron((1.0,), 32, 0)
    >>> round(float(np.linalg.norm(m.verts, axis=1).max()), 12), len(m.verts) == 3 * len(m.faces)
    (1.0, True)
    """
    (radius,) = size
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 25))
    for _ in range(64):
        pts = unit(rng.standard_normal((n, 3))) * rng.uniform(0.85, 1.0, (n, 1))
        faces = _hull(pts)
        tri = pts[faces]
        volume = np.einsum("ij,ij->i", tri[:, 0], cross(tri[:, 1], tri[:, 2])).sum() / 6
        if volume > 0.1:
            break
    pts = pts * (radius / np.linalg.norm(pts, axis=1).max())
    tri = pts[faces]
    e1 = unit(tri[:, 1] - tri[:, 0])
    e2 = cross(unit(cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])), e1)
    rel = tri - tri[:, :1]
    uv = np.stack([np.einsum("fkj,fj->fk", rel, e1), np.einsum("fkj,fj->fk", rel, e2)], -1)
    uv = uv - uv.min(axis=1, keepdims=True)
    extent = tuple(float(e) for e in uv.reshape(-1, 2).max(axis=0))
    return LocalMesh(tri.reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3),
                     uv.reshape(-1, 2), extent)


def wire(size: tuple[float, ...], segments: int, seed: int) -> LocalMesh:
    """A sagging, swaying cable: ``size = (length, thickness)``, a capped tube of diameter
    ``thickness`` along local ``x``.

    Centre line ``x`` from ``-(length - thickness)/2`` to ``+(length - thickness)/2``, a seeded
    asymmetric sag in ``y`` of up to 0.2 length (down is ``+y``, centred) and a sideways sway in
    ``z`` of up to 0.05 length. Vertices lie in ``|x| <= length/2``,
    ``|y| <= 0.1 length + thickness/2``, ``|z| <= 0.05 length + thickness/2``. Needs
    ``thickness <= WIRE_THICKNESS_RATIO * length`` (0.25). ``max(8, segments)`` rings of
    ``max(3, segments // 6)`` sides. Coords: side (arc length, arc around), caps beside.

    Examples
    --------
    >>> m = wire((2.0, 0.02), 16, 0)
    >>> float(m.verts[:, 0].max()) <= 1.0, m.faces.shape
    (True, (96, 3))
    """
    length, thick = size
    rng = np.random.default_rng(seed)
    n = max(8, segments)
    u = np.linspace(-1.0, 1.0, n)
    bulge = (1 - u * u) * (1 + rng.uniform(-0.5, 0.5) * u)
    sag = rng.uniform(0.0, 0.2) * length * (bulge / bulge.max() - 0.5)
    sway = rng.uniform(0.0, 0.05) * length * np.sin(
        math.pi * int(rng.integers(1, 3)) * (u + 1) / 2 + rng.uniform(-0.3, 0.3) * (1 - u * u))
    line = np.stack([(length - thick) / 2 * u, sag, sway], 1)
    return atlas_row(tube(line, np.full(n, thick / 2), max(3, segments // 6), closed=False,
                          reference=np.array([0.0, 0.0, 1.0])))
