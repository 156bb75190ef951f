"""Triangle meshes of scene objects, in world coordinates, textured.

Each :class:`~scenes.spec.ObjectSpec` becomes one ``trimesh.Trimesh`` (``process=False``) whose
vertices are already in the world (left camera) frame. Its visual is a
``trimesh.visual.TextureVisuals`` with one texture image from :func:`scenes.textures.texture_image`
and a white :class:`~trimesh.visual.material.SimpleMaterial` (the image is not darkened by
trimesh's default grey diffuse colour).

UVs follow OpenGL (``v = 1`` is image row 0: GL textures are uploaded bottom row first). Surface
coordinates are laid out in metres, so a texture frequency in cycles per metre is a frequency on
the surface: exactly on planes, boxes and cylinder sides and caps, along the equator and every
meridian of a sphere (longitude lines converge toward the poles), along the centre line of a
Moebius strip, and on the terrain's ground plan (slopes stretch it slightly). Boxes and cylinders
pack their faces into one atlas image; each face has its own vertices so texture seams are clean.

Fences and grids are unions of closed boxes (bars); every vertical bar shares one atlas chart and
every horizontal bar another, so the bars repeat their texture too. A ``"mesh"`` object is the
file's triangles (:func:`scenes.assets.load_mesh_file`) scaled and posed; it is textured by its
``texture`` on **generated** UVs (each face projected along the axis nearest its normal, in
metres: exact frequency on axis-facing faces, stretched by at most sqrt(3) elsewhere; faces get
their own corners, shading keeps the file's smooth vertex normals), or, with ``own_texture =
True`` and a file that has a texture image and UVs, by **its own** texture;
``mesh.metadata["texture_source"]`` says which (``"generated"`` or ``"own"``). A mesh is
double-sided unless it is watertight, consistently wound and of positive volume.

Closed kinds (box, sphere, cylinder, fence, grid) wind counter-clockwise seen from outside (outward normals,
right-handed frame). Open kinds (plane, moebius, terrain) are single surfaces that can be seen
from behind (the Moebius strip has no consistent side at all): ``mesh.metadata["double_sided"]``
is True for them and a renderer should not cull their back faces.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from PIL import Image

from scenes._meshkit import cross as _cross
from scenes._meshkit import grid_faces as _grid_faces
from scenes.assets import load_mesh_file
from scenes.families import FAMILY_BUILDERS, OPEN_FAMILIES, deform, subdivide
from scenes.spec import ObjectSpec, SceneSpec
from scenes.textures import band_limited_noise, texture_image

__all__ = ["build_mesh", "build_meshes", "plane_equation", "terrain_heights", "OPEN_KINDS",
           "FAMILY_MAX_SEGMENTS"]

#: Kinds whose meshes are open surfaces (render them double-sided).
OPEN_KINDS: frozenset[str] = frozenset({"plane", "moebius", "terrain"})

# A local mesh before texturing: vertices (N, 3), faces (M, 3), surface coords in metres (N, 2)
# laid out in an atlas of the given (width, height) in metres.
_Local = tuple[np.ndarray, np.ndarray, np.ndarray, tuple[float, float]]


# --------------------------------------------------------------------------- helpers
def _gutter(obj: ObjectSpec, largest: float) -> float:
    """Space between atlas charts: half a texture period, at most 5 % of the largest chart."""
    return min(0.5 / obj.texture.frequency, 0.05 * largest)


def _quad(center: np.ndarray, normal: np.ndarray, down: np.ndarray, la: float, lb: float
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rectangle facing ``normal``: ``u`` along ``normal x down`` (length ``la``), ``v`` along
    ``down`` (length ``lb``). Returns vertices (4, 3), faces (2, 3) and coords (4, 2)."""
    across = _cross(normal, down)
    uv = np.array([[0.0, 0.0], [la, 0.0], [la, lb], [0.0, lb]])
    verts = (center + (uv[:, :1] - la / 2) * across + (uv[:, 1:] - lb / 2) * down)
    faces = np.array([[0, 2, 1], [0, 3, 2]])  # normal = down x across
    return verts, faces, uv


def _merge(parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
           offsets: list[tuple[float, float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    verts, faces, coords, base = [], [], [], 0
    for (v, f, uv), off in zip(parts, offsets):
        verts.append(v)
        faces.append(f + base)
        coords.append(uv + np.asarray(off))
        base += len(v)
    return np.concatenate(verts), np.concatenate(faces), np.concatenate(coords)


# --------------------------------------------------------------------------- local meshes
def _plane(obj: ObjectSpec) -> _Local:
    w, h = obj.size
    v, f, uv = _quad(np.zeros(3), np.array([0.0, 0.0, -1.0]), np.array([0.0, 1.0, 0.0]), w, h)
    return v, f, uv, (w, h)


def _box(obj: ObjectSpec) -> _Local:
    return _box_local(*obj.size, _gutter(obj, max(obj.size)))


def _box_local(sx: float, sy: float, sz: float, g: float) -> _Local:
    """A box centred at the origin, its six faces in one atlas separated by the gutter ``g``."""
    x, y, z = np.eye(3)
    # (normal, down, la, lb); atlas: the four sides in row 0 (height sy), top and bottom in
    # row 1 (height sz), charts separated by a gutter g
    charts = [(-z, y, sx, sy), (z, y, sx, sy), (x, y, sz, sy), (-x, y, sz, sy),
              (-y, z, sx, sz), (y, z, sx, sz)]
    half = np.array([sx, sy, sz]) / 2
    parts, offsets = [], []
    cursor = [0.0, 0.0]  # next u offset in rows 0 and 1
    for i, (n, down, la, lb) in enumerate(charts):
        parts.append(_quad(n * half, n, down, la, lb))
        row = 0 if i < 4 else 1
        offsets.append((cursor[row], 0.0 if row == 0 else sy + g))
        cursor[row] += la + g
    extent = (max(cursor) - g, sy + g + sz)
    return (*_merge(parts, offsets), extent)


def _sphere(obj: ObjectSpec) -> _Local:
    (r,) = obj.size
    n_lon = obj.segments
    n_lat = max(2, n_lon // 2)
    theta = np.linspace(0.0, math.pi, n_lat + 1)  # from the top (-y) pole
    phi = np.linspace(0.0, 2 * math.pi, n_lon + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    verts = r * np.stack([np.sin(t) * np.cos(p), -np.cos(t), np.sin(t) * np.sin(p)], -1)
    verts[0] = (0.0, -r, 0.0)  # exact poles
    verts[-1] = (0.0, r, 0.0)
    verts = verts.reshape(-1, 3)
    faces = _grid_faces(n_lat, n_lon)
    # drop the degenerate halves of the cells touching the poles
    n_cells = n_lat * n_lon
    first, second = faces[:n_cells], faces[n_cells:]
    row = np.repeat(np.arange(n_lat), n_lon)
    faces = np.concatenate([first[row != n_lat - 1], second[row != 0]])
    coords = np.stack([r * p, r * t], -1).reshape(-1, 2)
    return verts, faces, coords, (2 * math.pi * r, math.pi * r)


def _cylinder(obj: ObjectSpec) -> _Local:
    r, h = obj.size
    n = obj.segments
    phi = np.linspace(0.0, 2 * math.pi, n + 1)
    ring = np.stack([r * np.cos(phi), np.zeros_like(phi), r * np.sin(phi)], -1)
    ring[-1] = ring[0]
    side_v = np.concatenate([ring + (0.0, -h / 2, 0.0), ring + (0.0, h / 2, 0.0)])
    side_f = _grid_faces(1, n)
    side_uv = np.stack([np.tile(r * phi, 2), np.repeat([0.0, h], n + 1)], -1)
    caps = []
    for y_cap, flip in ((-h / 2, True), (h / 2, False)):
        v = np.concatenate([[(0.0, y_cap, 0.0)], ring[:-1] + (0.0, y_cap, 0.0)])
        k = np.arange(n)
        f = np.stack([np.zeros(n, dtype=np.int64), 1 + (k + 1) % n, 1 + k], -1)
        if flip:
            f = f[:, [0, 2, 1]]
        caps.append((v, f, np.stack([v[:, 0] + r, v[:, 2] + r], -1)))
    g = _gutter(obj, max(2 * math.pi * r, h))
    offsets = [(0.0, 0.0), (0.0, h + g), (2 * r + g, h + g)]
    extent = (max(2 * math.pi * r, 4 * r + g), h + g + 2 * r)
    return (*_merge([(side_v, side_f, side_uv), *caps], offsets), extent)


def _moebius(obj: ObjectSpec) -> _Local:
    radius, width = obj.size
    n = obj.segments
    k = max(1, min(n, math.ceil(n * width / (2 * math.pi * radius))))
    s = np.linspace(-width / 2, width / 2, k + 1)
    t = np.linspace(0.0, 2 * math.pi, n + 1)
    ss, tt = np.meshgrid(s, t, indexing="ij")
    rad = radius + ss * np.cos(tt / 2)
    verts = np.stack([rad * np.cos(tt), rad * np.sin(tt), ss * np.sin(tt / 2)], -1)
    verts[:, -1] = verts[::-1, 0]  # close the strip exactly (with the half twist)
    coords = np.stack([radius * tt, ss + width / 2], -1)
    return verts.reshape(-1, 3), _grid_faces(k, n), coords.reshape(-1, 2), (2 * math.pi * radius,
                                                                          width)


def terrain_heights(obj: ObjectSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The relief of a ``"terrain"`` object in its local frame: grid coordinates ``x``
    ((nx + 1,) float64) and ``z`` ((nz + 1,)), and ``height`` ((nz + 1, nx + 1) float64, up is
    ``-y``: a vertex lies at ``(x, -height, z)``). What :func:`build_mesh` triangulates; use it
    to stand things on the ground (:mod:`scenes.layouts`)."""
    if not isinstance(obj, ObjectSpec) or obj.kind != "terrain":
        raise ValueError(f"terrain_heights needs an ObjectSpec of kind 'terrain', got {obj!r}")
    width, depth, amplitude = obj.size
    long_side = max(width, depth)
    nx = max(2, round(obj.segments * width / long_side))
    nz = max(2, round(obj.segments * depth / long_side))
    x = np.linspace(-width / 2, width / 2, nx + 1)
    z = np.linspace(-depth / 2, depth / 2, nz + 1)
    relief = band_limited_noise((nz + 1, nx + 1), frequency=4.0 / min(width, depth),
                                pixel_size=(width / nx, depth / nz),
                                rng=np.random.default_rng(obj.seed))
    peak = np.abs(relief).max()
    height = amplitude * relief / peak if peak > 0 else np.zeros_like(relief)
    return x, z, height


def _terrain(obj: ObjectSpec) -> _Local:
    width, depth, _ = obj.size
    x, z, height = terrain_heights(obj)
    nx, nz = len(x) - 1, len(z) - 1
    zz, xx = np.meshgrid(z, x, indexing="ij")
    verts = np.stack([xx, -height, zz], -1).reshape(-1, 3)
    coords = np.stack([xx + width / 2, zz + depth / 2], -1).reshape(-1, 2)
    faces = _grid_faces(nz, nx)[:, [0, 2, 1]]  # face up (-y)
    return verts, faces, coords, (width, depth)


def _bars(obj: ObjectSpec) -> _Local:
    """Fence (vertical bars) or grid (vertical bars, horizontal ones ``thickness`` behind).

    Every vertical bar shares one atlas chart (the same texture: a repetitive structure), every
    horizontal bar another, below it.
    """
    width, height, spacing, t = obj.size
    g = _gutter(obj, max(width, height))
    n_x = math.floor(width / spacing + 1e-9) + 1
    xs = (np.arange(n_x) - (n_x - 1) / 2) * spacing
    vert = _box_local(t, height, t, g)
    parts = [(vert[0] + (x, 0.0, 0.0), vert[1], vert[2]) for x in xs]
    offsets = [(0.0, 0.0)] * len(parts)
    extent = vert[3]
    if obj.kind == "grid":
        n_y = math.floor(height / spacing + 1e-9) + 1
        ys = (np.arange(n_y) - (n_y - 1) / 2) * spacing
        hor = _box_local(width, t, t, g)
        parts += [(hor[0] + (0.0, y, t), hor[1], hor[2]) for y in ys]
        offsets += [(0.0, extent[1] + g)] * n_y
        extent = (max(extent[0], hor[3][0]), extent[1] + g + hor[3][1])
    return (*_merge(parts, offsets), extent)


def _triplanar(verts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                np.ndarray, tuple[float, float]]:
    """Generated UVs in metres: each face projected along the axis its normal is closest to.

    Faces get their own corners (``(3 M, 3)`` vertices, faces ``arange``) so charts never share
    a texture coordinate; a surface frequency is exact on faces normal to an axis and stretched
    by at most ``sqrt(3)`` elsewhere. Every chart maps into one patch of the texture.
    """
    tri = verts[faces]
    normal = np.abs(_cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    axis = np.argmax(normal, axis=1)
    pick = np.array([[2, 1], [0, 2], [0, 1]])[axis]  # x: (z, y), y: (x, z), z: (x, y)
    corners = tri.reshape(-1, 3)
    index = np.repeat(pick, 3, axis=0)
    coords = np.take_along_axis(corners, index, axis=1)
    coords = coords - coords.min(axis=0)
    extent = tuple(float(max(e, 1e-9)) for e in coords.max(axis=0))
    return corners, np.arange(len(corners)).reshape(-1, 3), coords, extent


_BUILDERS = {"plane": _plane, "box": _box, "sphere": _sphere, "cylinder": _cylinder,
             "moebius": _moebius, "terrain": _terrain, "fence": _bars, "grid": _bars}


# --------------------------------------------------------------------------- public API
def build_mesh(obj: ObjectSpec) -> trimesh.Trimesh:
    """Textured triangle mesh of one object, in world coordinates.

    Parameters
    ----------
    obj : ObjectSpec
        The object (its ``pose`` is applied).

    Returns
    -------
    mesh : trimesh.Trimesh
        ``process=False``; ``mesh.visual`` is a ``TextureVisuals`` (``uv`` (N, 2) float64,
        ``material.image`` an RGB ``PIL.Image``); ``mesh.metadata`` holds ``name``, ``kind`` and
        ``double_sided`` (True for open surfaces, see :data:`OPEN_KINDS`).

    Examples
    --------
    >>> from scenes.spec import ObjectSpec, Pose, TextureSpec
    >>> plane = ObjectSpec("plane", Pose(translation=(0.0, 0.0, 2.0)), (2.0, 1.0),
    ...                    TextureSpec(frequency=8.0))
    >>> mesh = build_mesh(plane)
    >>> mesh.faces.shape, mesh.vertices[:, 2].tolist(), mesh.visual.material.image.size
    ((2, 3), [2.0, 2.0, 2.0, 2.0], (108, 54))
    """
    if not isinstance(obj, ObjectSpec):
        raise TypeError(f"obj must be an ObjectSpec, got {type(obj).__name__}")
    transform = obj.pose.matrix()
    metadata = {"name": obj.name, "kind": obj.kind,
                "double_sided": obj.kind in OPEN_KINDS or obj.kind in OPEN_FAMILIES}
    if obj.kind == "mesh":
        return _file_mesh(obj, transform, metadata)
    if obj.kind in FAMILY_BUILDERS:
        segments = min(obj.segments, FAMILY_MAX_SEGMENTS)
        verts, faces, coords, extent = FAMILY_BUILDERS[obj.kind](obj.size, segments, obj.seed)
    else:
        verts, faces, coords, extent = _BUILDERS[obj.kind](obj)
    verts, faces, coords = _deformed(obj, verts, faces, coords)
    world = verts @ transform[:3, :3].T + transform[:3, 3]
    return _textured(obj, world, faces, coords, extent, _vertex_normals(world, faces), metadata)


#: The families' tessellation stops here (a knot of 4096 segments would be ~38M triangles).
FAMILY_MAX_SEGMENTS = 256

#: A deformed object's triangles are split until every edge is below this fraction of its size
#: (so a bent box bends instead of shearing its two triangles per face).
_DEFORM_EDGE = 1.0 / 12


def _deformed(obj: ObjectSpec, verts: np.ndarray, faces: np.ndarray, coords: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The local mesh twisted, bent and tapered by ``obj.deform`` (unchanged when it is none)."""
    if not any(obj.deform):
        return verts, faces, coords
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    # about the origin: t = y / (height / 2) stays in [-1, 1] for shapes not centred on it
    height = 2 * max(abs(float(lo[1])), abs(float(hi[1])))
    if not height > 0:  # flat in y: nothing to deform along it
        return verts, faces, coords
    verts, faces, coords = subdivide(verts, faces, coords,
                                     max_edge=float(np.max(hi - lo)) * _DEFORM_EDGE)
    twist, bend, taper = obj.deform
    return deform(verts, extent=height, twist=twist, bend=bend, taper=taper), faces, coords


def _file_mesh(obj: ObjectSpec, transform: np.ndarray, metadata: dict) -> trimesh.Trimesh:
    """A mesh file's object: scaled, posed, textured by its own texture or on generated UVs."""
    data = load_mesh_file(obj.path)
    (scale,) = obj.size
    local = data.vertices * scale
    world = local @ transform[:3, :3].T + transform[:3, 3]
    normals = _vertex_normals(world, data.faces)
    metadata["double_sided"] = not data.closed
    if any(obj.deform):  # generated UVs on the deformed, finer triangles
        corners, faces, coords, extent = _triplanar(local, data.faces)
        corners, faces, coords = _deformed(obj, corners, faces, coords)
        world = corners @ transform[:3, :3].T + transform[:3, 3]
        metadata["texture_source"] = "generated"
        return _textured(obj, world, faces, coords, extent, _vertex_normals(world, faces),
                         metadata)
    if obj.own_texture and data.image is not None:
        metadata["texture_source"] = "own"
        material = _material(Image.fromarray(np.asarray(data.image), mode="RGB"), obj)
        visual = trimesh.visual.TextureVisuals(uv=np.asarray(data.uv), material=material)
        return trimesh.Trimesh(vertices=world, faces=data.faces, vertex_normals=normals,
                               visual=visual, process=False, validate=False, metadata=metadata)
    metadata["texture_source"] = "generated"
    corners, faces, coords, extent = _triplanar(local, data.faces)
    world = corners @ transform[:3, :3].T + transform[:3, 3]
    return _textured(obj, world, faces, coords, extent, normals[data.faces].reshape(-1, 3),
                     metadata)


def _material(image: Image.Image, obj: ObjectSpec) -> trimesh.visual.material.SimpleMaterial:
    return trimesh.visual.material.SimpleMaterial(
        image=image, diffuse=[255, 255, 255, 255], ambient=[255, 255, 255, 255],
        specular=[0, 0, 0, 255], name=obj.name or obj.kind)


def _textured(obj: ObjectSpec, world: np.ndarray, faces: np.ndarray, coords: np.ndarray,
              extent: tuple[float, float], normals: np.ndarray, metadata: dict
              ) -> trimesh.Trimesh:
    uv = np.column_stack([coords[:, 0] / extent[0], 1.0 - coords[:, 1] / extent[1]])
    material = _material(texture_image(obj.texture, extent=extent), obj)
    visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    return trimesh.Trimesh(vertices=world, faces=faces, vertex_normals=normals, visual=visual,
                           process=False, validate=False, metadata=metadata)


def _vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals of (N, 3) float64 vertices (zero for vertices of no
    face).

    Several times faster than trimesh's angle-weighted ones (scipy sparse sums), which they
    match to within a few degrees on these meshes; both follow the winding.
    """
    first = vertices[faces[:, 0]]
    face_n = _cross(vertices[faces[:, 1]] - first, vertices[faces[:, 2]] - first)  # 2 x area x n
    # one bincount over (vertex, axis) bins: each bin sums its faces in the order the three
    # per-axis bincounts of faces.T.ravel() did (all first corners, then second, then third)
    bins = (3 * faces.T.reshape(-1, 1) + np.arange(3)).ravel()
    normals = np.bincount(bins, np.tile(face_n, (3, 1)).ravel(),
                          minlength=3 * len(vertices)).reshape(-1, 3)
    # np.linalg.norm(normals, axis=1, keepdims=True), its expression
    length = np.sqrt(np.add.reduce(normals * normals, axis=1, keepdims=True))
    np.divide(normals, length, out=normals, where=length > 0)
    return normals


def build_meshes(spec: SceneSpec) -> list[trimesh.Trimesh]:
    """One mesh per object of ``spec``, in the same order (see :func:`build_mesh`).

    Examples
    --------
    >>> from scenes.spec import ObjectSpec, Pose, SceneSpec, TextureSpec
    >>> ball = ObjectSpec("sphere", Pose(translation=(0.0, 0.0, 3.0)), (0.5,),
    ...                   TextureSpec(frequency=10.0), segments=16)
    >>> [m.metadata["kind"] for m in build_meshes(SceneSpec("one ball", (ball,)))]
    ['sphere']
    """
    if not isinstance(spec, SceneSpec):
        raise TypeError(f"spec must be a SceneSpec, got {type(spec).__name__}")
    return [build_mesh(obj) for obj in spec.objects]


def plane_equation(obj: ObjectSpec) -> tuple[np.ndarray, float]:
    """World plane ``n . X = c`` of a ``"plane"`` object.

    Returns
    -------
    n : (3,) float64 array
        Unit normal of the side the plane faces (its local ``-z`` axis, in world coordinates).
    c : float
        Offset, ``n . translation``; ``-c`` is the signed distance of the camera centre along n.

    Raises
    ------
    ValueError
        If ``obj`` is not a plane.

    Examples
    --------
    >>> from scenes.spec import ObjectSpec, Pose, TextureSpec
    >>> n, c = plane_equation(ObjectSpec("plane", Pose(translation=(0.0, 0.0, 2.0)), (1.0, 1.0),
    ...                                  TextureSpec()))
    >>> n.tolist(), c
    ([0.0, 0.0, -1.0], -2.0)
    """
    if not isinstance(obj, ObjectSpec):
        raise TypeError(f"obj must be an ObjectSpec, got {type(obj).__name__}")
    if obj.kind != "plane":
        raise ValueError(f"plane_equation needs an object of kind 'plane', got {obj.kind!r} "
                         f"(name {obj.name!r})")
    rot = obj.pose.rotation()
    n = rot @ np.array([0.0, 0.0, -1.0])
    n = n / np.linalg.norm(n)
    return n, float(n @ np.asarray(obj.pose.translation))
