"""Mesh-building blocks shared by the object families (:mod:`scenes.families` and its rooms).

Everything here is local geometry in the camera-like object frame of :mod:`scenes.primitives`
(``y`` down, right-handed, closed parts wound counter-clockwise seen from outside) with surface
coordinates in metres. The module is private to ``scenes``; its names are public so that the
family modules may share them (no ``_private`` name crosses a module, see the import contracts).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

__all__ = ["LocalMesh", "Part", "grid_faces", "cross", "unit", "merge", "atlas_row", "frames",
           "tube", "frustums", "box", "cylinder", "revolve", "split_edges"]


class LocalMesh(NamedTuple):
    """A local mesh before texturing (the ``_Local`` tuple of :mod:`scenes.primitives`).

    ``verts`` (N, 3) float64, ``faces`` (M, 3) int64, ``coords`` (N, 2) float64 surface
    coordinates in metres inside an atlas of ``extent`` = (width, height) metres.
    """

    verts: np.ndarray
    faces: np.ndarray
    coords: np.ndarray
    extent: tuple[float, float]


class Part(NamedTuple):
    """A piece of a mesh: vertices, faces and coords with the (width, height) of its chart."""

    verts: np.ndarray
    faces: np.ndarray
    coords: np.ndarray
    extent: tuple[float, float]


def grid_faces(rows: int, cols: int) -> np.ndarray:
    """Faces of a (rows + 1) x (cols + 1) vertex grid, index ``r * (cols + 1) + c``.

    Counter-clockwise seen from the side where ``d_row x d_col`` points (as in
    :mod:`scenes.primitives`).
    """
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = (r * (cols + 1) + c).ravel()
    b = a + 1
    d = a + cols + 1
    cc = d + 1
    return np.concatenate([np.stack([a, d, cc], 1), np.stack([a, cc, b], 1)]).astype(np.int64)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` of (..., 3) arrays without its axis handling (faster on small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def unit(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` (..., 3) scaled to unit length (zero rows stay zero)."""
    n = np.sqrt(np.einsum("...i,...i->...", v, v))[..., None]
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def merge(parts: list[Part], offsets: list[tuple[float, float]]) -> tuple[np.ndarray, ...]:
    """Concatenate parts, shifting each one's coords by its atlas offset."""
    verts, faces, coords, base = [], [], [], 0
    for part, off in zip(parts, offsets):
        verts.append(part.verts)
        faces.append(part.faces + base)
        coords.append(part.coords + np.asarray(off))
        base += len(part.verts)
    return np.concatenate(verts), np.concatenate(faces), np.concatenate(coords)


def atlas_row(parts: list[Part]) -> LocalMesh:
    """One mesh from parts whose charts sit side by side along ``u`` (gutter 2 % of the
    largest chart side). Parts meant to share a chart (the same texture) are merged first."""
    g = 0.02 * max(max(p.extent) for p in parts)
    offsets, u = [], 0.0
    for p in parts:
        offsets.append((u, 0.0))
        u += p.extent[0] + g
    extent = (u - g, max(p.extent[1] for p in parts))
    return LocalMesh(*merge(parts, offsets), (float(extent[0]), float(extent[1])))


def frames(points: np.ndarray, *, closed: bool, reference: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rotation-minimising (parallel-transport) frames along a polyline (K, 3).

    A reference frame ``U0 = T x reference`` (``reference`` must never be parallel to the
    tangent) is turned by the accumulated transport angle: each step's minimal rotation, which
    takes ``T_k`` to ``T_k+1``, carries ``U_k`` to the ``U_k+1`` of the result. On a closed curve
    the holonomy left after one loop (reduced to (-pi, pi]) is spread evenly, so the frame closes.
    Returns unit tangents ``T``, normals ``U`` and binormals ``V = T x U``, each (K, 3).
    """
    if closed:
        t = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)
    else:
        t = np.gradient(points, axis=0)
    t = unit(t)
    u0 = unit(cross(t, reference))
    v0 = cross(t, u0)
    nxt = np.roll(np.arange(len(t)), -1) if closed else np.arange(1, len(t))
    a, b = t[: len(nxt)], t[nxt]
    c = np.einsum("ij,ij->i", a, b)[:, None]
    w = cross(a, b)
    ua = u0[: len(nxt)]
    ru = c * ua + cross(w, ua) + w * (np.einsum("ij,ij->i", w, ua)[:, None] / (1.0 + c))
    delta = np.arctan2(np.einsum("ij,ij->i", ru, v0[nxt]), np.einsum("ij,ij->i", ru, u0[nxt]))
    alpha = np.concatenate([[0.0], np.cumsum(delta)])
    if closed:
        loop = (alpha[-1] + math.pi) % (2 * math.pi) - math.pi
        alpha = alpha[:-1] - loop * np.arange(len(t)) / len(t)
    ca, sa = np.cos(alpha)[:, None], np.sin(alpha)[:, None]
    u = ca * u0 + sa * v0
    return t, u, cross(t, u)


def _arc(points: np.ndarray, closed: bool) -> np.ndarray:
    ends = np.concatenate([points, points[:1]]) if closed else points
    steps = np.linalg.norm(np.diff(ends, axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def tube(points: np.ndarray, radius: np.ndarray, sides: int, *, closed: bool,
         reference: np.ndarray) -> list[Part]:
    """Tube of (K,) ``radius`` around a polyline (K, 3) on rotation-minimising frames.

    Closed: one part, the seam ring repeated (the same bits) for the texture. Open: the side and
    two flat caps (fans), three parts, so the tube is closed either way. Side coords: (arc length
    along the line, ``radius * angle``), chart (length, 2 pi max radius); caps: the disc's own
    plane, chart (2 r, 2 r).
    """
    t, u, v = frames(points, closed=closed, reference=reference)
    phi = np.linspace(0.0, 2 * math.pi, sides + 1)
    cp, sp = np.cos(phi), np.sin(phi)
    ring = cp[None, :, None] * u[:, None] + sp[None, :, None] * v[:, None]
    verts = points[:, None] + radius[:, None, None] * ring
    verts[:, -1] = verts[:, 0]
    s = _arc(points, closed)
    rad = radius
    if closed:
        verts = np.concatenate([verts, verts[:1]])
        rad = np.append(radius, radius[0])
    rows = len(verts) - 1
    coords = np.stack([np.broadcast_to(s[:, None], (rows + 1, sides + 1)),
                       rad[:, None] * phi[None]], -1)
    side = Part(verts.reshape(-1, 3), grid_faces(rows, sides)[:, [0, 2, 1]],
                coords.reshape(-1, 2), (float(s[-1]), float(2 * math.pi * rad.max())))
    if closed:
        return [side]
    caps = []
    for k, sign in ((0, -1.0), (-1, 1.0)):
        r = float(radius[k])
        rim = points[k] + r * ring[k, :-1]
        cv = np.concatenate([points[k][None], rim])
        j = np.arange(sides)
        f = np.stack([np.zeros(sides, np.int64), 1 + j, 1 + (j + 1) % sides], -1)
        if sign < 0:
            f = f[:, [0, 2, 1]]
        uv = r + r * np.stack([np.concatenate([[0.0], cp[:-1]]),
                               np.concatenate([[0.0], sp[:-1]])], -1)
        caps.append(Part(cv, f, uv, (2 * r, 2 * r)))
    return [side, *caps]


def frustums(p0: np.ndarray, p1: np.ndarray, r0: np.ndarray, r1: np.ndarray, sides: int
             ) -> tuple[Part, Part]:
    """B straight tapered tubes from ``p0`` (B, 3) to ``p1`` with end radii ``r0``, ``r1`` (B,),
    each closed by two flat caps. Returns the sides (one shared chart: length x 2 pi r) and the
    caps (one shared chart: 2 r x 2 r)."""
    b = len(p0)
    axis = p1 - p0
    length = np.linalg.norm(axis, axis=1)
    t = axis / length[:, None]
    ref = np.where((np.abs(t[:, 0]) < 0.9)[:, None], [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    u = unit(cross(t, ref))
    v = cross(t, u)
    phi = np.linspace(0.0, 2 * math.pi, sides + 1)
    cp, sp = np.cos(phi), np.sin(phi)
    ring = cp[None, :, None] * u[:, None] + sp[None, :, None] * v[:, None]  # (B, S+1, 3)
    ring[:, -1] = ring[:, 0]
    ends = np.stack([p0, p1], 1)[:, :, None]  # (B, 2, 1, 3)
    radii = np.stack([r0, r1], 1)  # (B, 2)
    sv = ends + radii[:, :, None, None] * ring[:, None]  # (B, 2, S+1, 3)
    n_side = 2 * (sides + 1)
    base = (np.arange(b) * n_side)[:, None, None]
    sf = (grid_faces(1, sides)[:, [0, 2, 1]][None] + base).reshape(-1, 3)
    su = np.broadcast_to(np.stack([np.zeros(b), length], 1)[:, :, None], (b, 2, sides + 1))
    suv = np.stack([su, radii[:, :, None] * phi], -1)
    side = Part(sv.reshape(-1, 3), sf, suv.reshape(-1, 2),
                (float(length.max()), float(2 * math.pi * radii.max())))
    # caps: centre + S rim vertices each; cap 0 faces -t, cap 1 faces +t
    cv = np.concatenate([ends[:, :, 0][:, :, None], sv[:, :, :-1]], 2)  # (B, 2, S+1, 3)
    j = np.arange(sides)
    fan = np.stack([np.zeros(sides, np.int64), 1 + j, 1 + (j + 1) % sides], -1)
    fans = np.stack([fan[:, [0, 2, 1]], fan])  # (2, S, 3)
    cbase = (np.arange(2 * b) * (sides + 1)).reshape(b, 2, 1, 1)
    cf = (fans[None] + cbase).reshape(-1, 3)
    disc = np.stack([np.concatenate([[0.0], cp[:-1]]), np.concatenate([[0.0], sp[:-1]])], -1)
    rmax = float(radii.max())
    cuv = rmax + radii[:, :, None, None] * disc
    caps = Part(cv.reshape(-1, 3), cf, cuv.reshape(-1, 2), (2 * rmax, 2 * rmax))
    return side, caps


def box(size: tuple[float, float, float], center: tuple[float, float, float] = (0.0, 0.0, 0.0)
        ) -> Part:
    """Closed axis-aligned box; its six faces (own corners) packed into one chart."""
    sx, sy, sz = size
    g = 0.02 * max(size)
    x, y, z = np.eye(3)
    # (normal, down, la, lb, u offset, v offset): sides in row 0 (height sy), top/bottom row 1
    charts = [(-z, y, sx, sy, 0.0, 0.0), (z, y, sx, sy, sx + g, 0.0),
              (x, y, sz, sy, 2 * (sx + g), 0.0), (-x, y, sz, sy, 2 * (sx + g) + sz + g, 0.0),
              (-y, z, sx, sz, 0.0, sy + g), (y, z, sx, sz, sx + g, sy + g)]
    half = np.array(size) / 2
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    verts, coords = [], []
    for n, down, la, lb, ou, ov in charts:
        across = cross(n, down)
        q = uv * (la, lb)
        verts.append(n * half + (q[:, :1] - la / 2) * across + (q[:, 1:] - lb / 2) * down)
        coords.append(q + (ou, ov))
    faces = (np.array([[0, 2, 1], [0, 3, 2]])[None] + 4 * np.arange(6)[:, None, None])
    extent = (2 * (sx + sz) + 3 * g, sy + g + sz)
    return Part(np.concatenate(verts) + np.asarray(center), faces.reshape(-1, 3),
                np.concatenate(coords), extent)


def cylinder(radius: float, height: float, sides: int,
             center: tuple[float, float, float] = (0.0, 0.0, 0.0), top: float | None = None
             ) -> Part:
    """Closed vertical (local ``y``) cylinder or frustum (``top``: radius at ``-y``), capped;
    side chart (2 pi r, h) and the two cap discs beside each other below it."""
    rt = radius if top is None else top
    profile = np.array([[0.0, height / 2], [radius, height / 2], [rt, -height / 2],
                        [0.0, -height / 2]])
    part = revolve([profile[:2], profile[1:3], profile[2:]], sides, max(radius, rt))
    return Part(part.verts + np.asarray(center), part.faces, part.coords, part.extent)


def revolve(pieces: list[np.ndarray], sides: int, ref_radius: float) -> Part:
    """Surface of revolution about local ``y`` of a profile in the (rho, y) half plane.

    ``pieces`` are (J_i, 2) polylines, each one's last point the next one's first (a crease
    between pieces: their vertices are not shared, so shading keeps the edge sharp). The whole
    profile runs from an axis point to an axis point (a solid) or is a loop (a ring-shaped solid);
    rows on the axis collapse to one point and their degenerate triangles are dropped. The winding
    follows the sign of the profile's area, so the surface faces outward either way. Coords:
    (``ref_radius * angle``, arc length along the profile), chart (2 pi ref_radius, length).
    """
    phi = np.linspace(0.0, 2 * math.pi, sides + 1)
    cp, sp = np.cos(phi), np.sin(phi)
    cp[-1], sp[-1] = 1.0, 0.0
    prof = np.concatenate(pieces)
    rho, y = prof[:, 0], prof[:, 1]
    area = float(np.sum(rho * np.roll(y, -1) - np.roll(rho, -1) * y))
    rows = len(prof) - 1
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(rho), np.diff(y)))])
    verts = np.stack([rho[:, None] * cp, np.broadcast_to(y[:, None], (rows + 1, sides + 1)),
                      rho[:, None] * sp], -1).reshape(-1, 3)
    # one grid over all rows; the bands between two pieces (a row repeated) are dropped, and so
    # are the degenerate halves of cells on the axis
    faces = grid_faces(rows, sides)
    row = np.tile(np.repeat(np.arange(rows), sides), 2)
    first = np.arange(len(faces)) < rows * sides
    joint = np.zeros(rows, bool)
    joint[np.cumsum([len(p) for p in pieces[:-1]]) - 1] = True
    axis = rho == 0.0
    drop = joint[row] | (first & axis[row + 1]) | (~first & axis[row])
    faces = faces[~drop]
    if area < 0:
        faces = faces[:, [0, 2, 1]]
    coords = np.stack([np.broadcast_to(ref_radius * phi, (rows + 1, sides + 1)),
                       np.broadcast_to(s[:, None], (rows + 1, sides + 1))], -1)
    return Part(verts, faces, coords.reshape(-1, 2), (2 * math.pi * ref_radius, float(s[-1])))


def split_edges(verts: np.ndarray, faces: np.ndarray, coords: np.ndarray, split: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the marked edges of a triangle mesh at their midpoints, crack-free.

    ``split`` (M, 3) bool marks edge ``k`` of each face (from corner ``k`` to ``k + 1``); both
    faces of an edge must agree (they do when the mark depends on the edge's end positions
    only). Each face becomes 1, 2, 3 or 4 triangles (4: the midpoint 1-to-4 split). A midpoint
    is made once per edge (end indices sorted), so neighbours share it; coords interpolate
    linearly.
    """
    m = len(faces)
    a, b = faces, np.roll(faces, -1, axis=1)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    key = lo.astype(np.int64) * len(verts) + hi
    marked = key[split]
    uniq, inverse = np.unique(marked, return_inverse=True)
    ulo, uhi = uniq // len(verts), uniq % len(verts)
    new_v = np.concatenate([verts, (verts[ulo] + verts[uhi]) / 2])
    new_c = np.concatenate([coords, (coords[ulo] + coords[uhi]) / 2])
    mid = np.full((m, 3), -1, np.int64)
    mid[split] = len(verts) + inverse.ravel()
    count = split.sum(axis=1)
    out = [faces[count == 0]]
    # one split edge: rotate so it is edge 0 (corners c0 c1 c2, midpoint m0 of c0-c1)
    for k in (1, 2, 3):
        sel = np.nonzero(count == k)[0]
        if not sel.size:
            continue
        f, md, sp = faces[sel], mid[sel], split[sel]
        if k == 1:
            shift = np.argmax(sp, axis=1)
        elif k == 2:
            shift = (np.argmin(sp, axis=1) + 1) % 3  # unsplit edge becomes edge 2
        else:
            shift = np.zeros(len(sel), np.int64)
        order = (shift[:, None] + np.arange(3)) % 3
        c = np.take_along_axis(f, order, axis=1)
        mm = np.take_along_axis(md, order, axis=1)
        c0, c1, c2, m0, m1, m2 = c[:, 0], c[:, 1], c[:, 2], mm[:, 0], mm[:, 1], mm[:, 2]
        if k == 1:
            tris = [(c0, m0, c2), (m0, c1, c2)]
        elif k == 2:  # edges 0 (c0-c1) and 1 (c1-c2) split
            tris = [(c0, m0, m1), (m0, c1, m1), (c0, m1, c2)]
        else:
            tris = [(c0, m0, m2), (m0, c1, m1), (m2, m1, c2), (m0, m1, m2)]
        out.extend(np.stack(t, 1) for t in tris)
    return new_v, np.concatenate(out).astype(np.int64), new_c
