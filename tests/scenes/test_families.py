"""Object families: deterministic, inside their documented bounds, closed where they say so;
deform and subdivide keep what they promise."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from scenes.primitives import build_mesh
from scenes.spec import DEFORM_LIMITS, FAMILY_KINDS, ObjectSpec, Pose, TextureSpec
from scenes.strategies import sizes
from scenes.families import (
    FAMILY_BUILDERS,
    FAMILY_SIZES,
    KNOT_TUBE_RATIO,
    OPEN_FAMILIES,
    WIRE_THICKNESS_RATIO,
    deform,
    family_size_problem,
    subdivide,
)

# a valid size per kind, away from the round numbers a bug could hide behind
_SIZES = {
    "superquadric": (0.7, 1.3, 0.45), "rock": (0.6,), "torus": (0.8, 0.25),
    "knot": (0.9, 0.9 * KNOT_TUBE_RATIO), "revolution": (0.25, 0.7), "extrusion": (0.5, 0.15),
    "polyhedron": (0.4,), "tree": (2.5, 4.0), "bush": (1.2, 0.8), "wire": (1.7, 0.03),
    "furniture": (1.1, 0.8, 0.6),
}
_SEEDS = (0, 1, 7, 2024, 987654321)
_SEEDLESS = {"torus"}  # its size fixes its shape
_CLOSED = sorted(set(FAMILY_BUILDERS) - OPEN_FAMILIES)
_RTOL = 1e-9


def _build(kind: str, seed: int, segments: int = 32, size: tuple | None = None):
    return FAMILY_BUILDERS[kind](_SIZES[kind] if size is None else size, segments, seed)


def _signed_volume(verts: np.ndarray, faces: np.ndarray) -> float:
    tri = verts[faces]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)


def _positions(verts: np.ndarray) -> np.ndarray:
    """Index of each vertex's exact position (seam duplicates share one)."""
    return np.unique(verts, axis=0, return_inverse=True)[1].ravel()


def _directed_edges_balance(verts: np.ndarray, faces: np.ndarray) -> bool:
    """Every edge a -> b (by position) is matched by as many b -> a: a union of closed,
    consistently wound surfaces (parts may touch, as furniture parts do)."""
    p = _positions(verts)[faces]
    a, b = p.ravel(), np.roll(p, -1, axis=1).ravel()
    n = int(p.max()) + 1
    return bool(np.array_equal(np.sort(a * n + b), np.sort(b * n + a)))


def _check_bounds(kind: str, size: tuple, v: np.ndarray) -> None:
    """The bounds each builder's docstring states (attained where it says so)."""
    tol = _RTOL * max(size)
    x, y, z = v.T
    rho_xz, norm = np.hypot(x, z), np.linalg.norm(v, axis=1)
    if kind in ("superquadric", "furniture"):
        assert (np.abs(v) <= np.array(size) / 2 + tol).all()
        if kind == "superquadric":
            np.testing.assert_allclose(np.ptp(v, axis=0), size, rtol=1e-12)
        else:  # on the ground, up to the top
            assert y.max() == pytest.approx(size[1] / 2) and y.min() == pytest.approx(-size[1] / 2)
    elif kind in ("rock", "polyhedron", "knot"):
        assert norm.max() <= size[0] + tol
        if kind != "knot":
            assert norm.max() == pytest.approx(size[0], rel=1e-12)
    elif kind == "torus":
        r, t = size
        assert (np.abs(v) <= np.array([r + t, r + t, t]) + tol).all()
    elif kind == "revolution":
        assert rho_xz.max() <= size[0] + tol and rho_xz.max() == pytest.approx(size[0], rel=1e-12)
        assert np.ptp(y) == pytest.approx(size[1], rel=1e-12) and np.abs(y).max() <= size[1] / 2
    elif kind == "extrusion":
        assert np.hypot(x, y).max() <= size[0] + tol
        assert np.abs(z).max() == pytest.approx(size[1] / 2, rel=1e-12)
    elif kind in ("tree", "bush"):
        w, h = size
        assert np.abs(v[:, [0, 2]]).max() <= w / 2 + tol and np.abs(y).max() <= h / 2 + tol
        if kind == "tree":  # the trunk stands on the ground
            assert y.max() == pytest.approx(h / 2, rel=1e-12)
    elif kind == "wire":
        length, t = size
        assert (np.abs(v) <= np.array([length / 2, 0.1 * length + t / 2, 0.05 * length + t / 2])
                + tol).all()
    else:  # pragma: no cover - a new kind needs its bounds here
        raise AssertionError(f"no bounds for {kind}")


def test_registry_is_consistent() -> None:
    assert set(FAMILY_SIZES) == set(FAMILY_BUILDERS) == set(_SIZES)
    assert OPEN_FAMILIES == {"tree", "bush"}
    for kind, labels in FAMILY_SIZES.items():
        assert len(labels) == len(_SIZES[kind]) and family_size_problem(kind, _SIZES[kind]) is None


@pytest.mark.parametrize("kind", sorted(FAMILY_BUILDERS))
@pytest.mark.parametrize("segments", [3, 32])
def test_builders_are_deterministic_valid_and_bounded(kind: str, segments: int) -> None:
    size = _SIZES[kind]
    for seed in _SEEDS:
        v, f, c, extent = _build(kind, seed, segments)
        again = _build(kind, seed, segments)
        for a, b in zip((v, f, c), again[:3]):
            assert a.tobytes() == b.tobytes()
        assert extent == again[3]
        assert v.dtype == np.float64 and v.ndim == 2 and v.shape[1] == 3
        assert f.dtype == np.int64 and f.ndim == 2 and f.shape[1] == 3 and len(f) > 0
        assert c.dtype == np.float64 and c.shape == (len(v), 2)
        assert np.isfinite(v).all() and np.isfinite(c).all()
        assert f.min() >= 0 and f.max() < len(v)
        assert len(extent) == 2 and all(isinstance(e, float) and e > 0 for e in extent)
        assert (c >= -_RTOL * max(extent)).all()
        assert (c <= np.array(extent) * (1 + _RTOL)).all()
        tri = v[f]
        area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        assert (area <= 1e-12 * area.max()).mean() <= 1e-3
        _check_bounds(kind, size, v)


@pytest.mark.parametrize("kind", sorted(set(FAMILY_BUILDERS) - _SEEDLESS))
def test_different_seeds_give_different_shapes(kind: str) -> None:
    meshes = [_build(kind, seed)[0] for seed in _SEEDS]
    for i in range(len(meshes)):
        for j in range(i):
            assert meshes[i].shape != meshes[j].shape or not np.array_equal(meshes[i], meshes[j])


@pytest.mark.parametrize("kind", _CLOSED)
@pytest.mark.parametrize("segments", [3, 24, 64])
def test_closed_kinds_are_watertight_and_wound_outward(kind: str, segments: int) -> None:
    for seed in _SEEDS:
        v, f, _, _ = _build(kind, seed, segments)
        assert _directed_edges_balance(v, f)
        assert _signed_volume(v, f) > 0
        if kind != "furniture":  # parts of furniture touch: not one manifold when merged
            merged = trimesh.Trimesh(v, f, process=False)
            merged.merge_vertices()
            assert merged.is_watertight and merged.is_winding_consistent
            assert merged.volume > 0


def test_torus_volume_and_superquadric_extremes() -> None:
    v, f, _, _ = FAMILY_BUILDERS["torus"]((0.8, 0.25), 256, 0)
    assert _signed_volume(v, f) == pytest.approx(2 * math.pi**2 * 0.8 * 0.25**2, rel=1e-3)
    # a superquadric's exponents vary with the seed: some nearly boxes, some pinched
    fill = [_signed_volume(*_build("superquadric", s, 64)[:2]) / np.prod(_SIZES["superquadric"])
            for s in range(40)]
    assert min(fill) < 0.45 and max(fill) > 0.8


@pytest.mark.parametrize("kind", sorted(FAMILY_BUILDERS))
def test_triangle_budget_at_64_segments(kind: str) -> None:
    budget = 30_000 if kind in OPEN_FAMILIES else 20_000
    assert max(len(_build(kind, seed, 64)[1]) for seed in range(12)) < budget


def _knot_clearance(seed: int, tube_ratio: float, segments: int = 48) -> float:
    """Smallest distance from a knot vertex to the tube's centre line, over the tube radius.

    The centre line is the mean of each ring (rings of ``sides + 1`` vertices, the last
    repeating the first). It is >= 1 when the tube never enters itself."""
    radius = 1.0
    v = FAMILY_BUILDERS["knot"]((radius, tube_ratio * radius), segments, seed)[0]
    sides = max(3, segments // 4)
    rings = v.reshape(-1, sides + 1, 3)
    centre = rings[:, :-1].mean(axis=1)
    d = np.linalg.norm(v[:, None] - centre[None], axis=2).min(axis=1)
    return float(d.min() / (tube_ratio * radius))


def test_knot_tube_clears_itself_up_to_the_ratio() -> None:
    shapes = set()
    for seed in range(30):
        assert _knot_clearance(seed, KNOT_TUBE_RATIO) >= 0.999
        shapes.add(len(FAMILY_BUILDERS["knot"]((1.0, 0.1), 16, seed)[1]))
    assert len(shapes) >= 3  # several (p, q)
    # the check sees an intersection: a tube twice too thick enters its neighbours
    assert min(_knot_clearance(seed, 2.5 * KNOT_TUBE_RATIO) for seed in range(30)) < 0.95


def test_family_size_problem_names_the_condition() -> None:
    assert "tube < radius" in family_size_problem("torus", (0.5, 0.5))
    assert "meets itself" in family_size_problem("knot", (1.0, 0.2))
    assert family_size_problem("knot", (1.0, KNOT_TUBE_RATIO)) is None
    assert "thickness" in family_size_problem("wire", (1.0, 2 * WIRE_THICKNESS_RATIO))
    assert "needs 3 size values" in family_size_problem("furniture", (1.0, 1.0))
    assert "> 0" in family_size_problem("rock", (-1.0,))
    assert "> 0" in family_size_problem("rock", (math.nan,))
    assert "unknown family" in family_size_problem("teapot", (1.0,))


# --------------------------------------------------------------------------- deform
_rng = np.random.default_rng(5)
_POINTS = _rng.uniform(-0.5, 0.5, (200, 3)) * (0.6, 2.0, 0.8)  # inside a 0.6 x 2 x 0.8 box


def test_deform_with_zero_parameters_is_the_identity_bit_for_bit() -> None:
    out = deform(_POINTS, extent=2.0)
    assert out.tobytes() == _POINTS.tobytes() and out is not _POINTS
    assert deform(_POINTS, extent=2.0, twist=0.0, bend=0.0, taper=0.0).tobytes() == \
        _POINTS.tobytes()


@pytest.mark.parametrize("twist", [0.3, -2.0, 7.0])
def test_twist_keeps_the_distance_to_the_axis_and_the_height(twist: float) -> None:
    out = deform(_POINTS, extent=2.0, twist=twist)
    np.testing.assert_allclose(np.hypot(out[:, 0], out[:, 2]),
                               np.hypot(_POINTS[:, 0], _POINTS[:, 2]), rtol=1e-12)
    np.testing.assert_array_equal(out[:, 1], _POINTS[:, 1])
    # the top and bottom slices turn by -twist/2 and +twist/2 about +y
    ends = deform(np.array([[1.0, -1.0, 0.0], [1.0, 1.0, 0.0]]), extent=2.0, twist=twist)
    angle = np.arctan2(-ends[:, 2], ends[:, 0])
    np.testing.assert_allclose(np.angle(np.exp(1j * (angle - [-twist / 2, twist / 2]))), 0.0,
                               atol=1e-12)


@pytest.mark.parametrize("taper", [0.4, -0.7])
def test_taper_scales_with_height_and_keeps_the_middle(taper: float) -> None:
    out = deform(_POINTS, extent=2.0, taper=taper)
    k = 1 + taper * _POINTS[:, 1]
    np.testing.assert_allclose(out[:, [0, 2]], _POINTS[:, [0, 2]] * k[:, None], rtol=1e-12)
    middle = _POINTS * (1.0, 0.0, 1.0)
    np.testing.assert_array_equal(deform(middle, extent=2.0, taper=taper), middle)


@pytest.mark.parametrize("bend", [0.2, 1.5, -3.0, 2 * math.pi])
def test_bend_keeps_the_axis_length_and_the_slices(bend: float) -> None:
    axis = np.column_stack([np.zeros(2001), np.linspace(-1.0, 1.0, 2001), np.zeros(2001)])
    arc = deform(axis, extent=2.0, bend=bend)
    assert np.linalg.norm(np.diff(arc, axis=0), axis=1).sum() == pytest.approx(2.0, rel=1e-6)
    np.testing.assert_array_equal(arc[1000], [0.0, 0.0, 0.0])  # y = 0 stays put
    # the axis lies on a circle of radius extent / bend about (extent / bend, 0)
    r = 2.0 / bend
    np.testing.assert_allclose(np.hypot(arc[:, 0] - r, arc[:, 1]), abs(r), rtol=1e-9)
    # each slice moves rigidly: distances inside it are kept
    slab = np.array([[-0.3, 0.7, -0.2], [0.25, 0.7, 0.1], [0.1, 0.7, 0.4]])
    out = deform(slab, extent=2.0, bend=bend)
    np.testing.assert_allclose(np.linalg.norm(out[:, None] - out[None], axis=2),
                               np.linalg.norm(slab[:, None] - slab[None], axis=2), atol=1e-12)
    if bend == 2 * math.pi:  # a full turn closes the axis into a circle
        np.testing.assert_allclose(arc[0], arc[-1], atol=1e-12)


def test_deform_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        deform(np.zeros((4, 2)), extent=1.0)
    with pytest.raises(ValueError, match="taper"):
        deform(_POINTS, extent=1.0, taper=1.0)
    with pytest.raises(ValueError, match="extent"):
        deform(_POINTS, extent=0.0)


# --------------------------------------------------------------------------- subdivide
def _edges(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    return np.linalg.norm(v[np.roll(f, -1, axis=1)] - v[f], axis=2)


@pytest.mark.parametrize("kind", ["polyhedron", "extrusion", "superquadric", "furniture"])
def test_subdivide_keeps_the_surface_closed_and_bounds_the_edges(kind: str) -> None:
    v, f, c, _ = _build(kind, 3, 16)
    bound = 0.3 * _edges(v, f).max()
    v2, f2, c2 = subdivide(v, f, c, max_edge=bound)
    assert _edges(v2, f2).max() < bound
    assert len(f2) > len(f) and np.array_equal(v2[: len(v)], v)
    assert _directed_edges_balance(v2, f2)
    if kind != "furniture":
        merged = trimesh.Trimesh(v2, f2, process=False)
        merged.merge_vertices()
        assert merged.is_watertight and merged.is_winding_consistent
    # flat faces are split in their plane: area and volume stay (up to rounding)
    area = trimesh.Trimesh(v, f, process=False).area
    assert trimesh.Trimesh(v2, f2, process=False).area == pytest.approx(area, rel=1e-12)
    if kind in ("polyhedron", "extrusion"):
        assert _signed_volume(v2, f2) == pytest.approx(_signed_volume(v, f), rel=1e-12)


def test_subdivide_interpolates_coords_linearly() -> None:
    v = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    v2, f2, c2 = subdivide(v, f, v[:, :2] * 3.0, max_edge=0.2)
    np.testing.assert_allclose(c2, v2[:, :2] * 3.0, rtol=1e-15, atol=1e-15)
    assert _edges(v2, f2).max() < 0.2
    assert trimesh.Trimesh(v2, f2, process=False).area == pytest.approx(2.0, rel=1e-14)
    normals = np.cross(v2[f2[:, 1]] - v2[f2[:, 0]], v2[f2[:, 2]] - v2[f2[:, 0]])
    assert (normals[:, 2] > 0).all()  # the winding is kept


def test_subdivide_stops_at_its_caps() -> None:
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    f, c = np.array([[0, 1, 2]]), np.zeros((3, 2))
    _, f2, _ = subdivide(v, f, c, max_edge=1e-6, max_levels=3)
    assert len(f2) == 4**3
    _, f3, _ = subdivide(v, f, c, max_edge=1e-6, max_faces=100)
    assert len(f3) == 4**3  # a fourth round would make 256 > 100
    with pytest.raises(ValueError, match="max_edge"):
        subdivide(v, f, c, max_edge=0.0)
    with pytest.raises(ValueError, match="faces index"):
        subdivide(v, f + 1, c, max_edge=0.1)


def test_a_subdivided_box_bends_smoothly_and_stays_closed() -> None:
    size = (0.4, 2.0, 0.3)  # a table top, on its side
    box = trimesh.creation.box(extents=size)
    v, f = np.asarray(box.vertices), np.asarray(box.faces, dtype=np.int64)
    v2, f2, c2 = subdivide(v, f, np.zeros((len(v), 2)), max_edge=0.1)
    bent = deform(v2, extent=size[1], bend=1.2, twist=0.5, taper=0.2)
    assert _directed_edges_balance(bent, f2)
    # bending keeps the volume (each slice's area scales by (R - x) / R, x symmetric);
    # the taper scales it by the mean of (1 + taper t)^2 over t in [-1, 1]
    volume = np.prod(size) * (1 + 0.2**2 / 3)
    assert _signed_volume(bent, f2) == pytest.approx(volume, rel=0.02)
    # away from the box's edges neighbouring faces turn by little: the bend is smooth
    angles = np.degrees(trimesh.Trimesh(bent, f2, process=False).face_adjacency_angles)
    assert angles[angles < 45.0].max() < 10.0


# --------------------------------------------------------------------------- through the spec
@settings(deadline=None)
@given(st.sampled_from(FAMILY_KINDS).flatmap(lambda kind: st.tuples(st.just(kind),
                                                                    sizes(kind))),
       st.tuples(st.floats(-DEFORM_LIMITS[0], DEFORM_LIMITS[0]),
                 st.floats(-DEFORM_LIMITS[1], DEFORM_LIMITS[1]),
                 st.floats(-DEFORM_LIMITS[2], DEFORM_LIMITS[2])),
       st.integers(3, 4096), st.integers(0, 2**63 - 1))
def test_any_family_object_builds_a_finite_bounded_mesh(kind_size, deform, segments, seed):
    """Every size the spec accepts, any deformation within its bounds, any tessellation and
    seed: finite vertices within the object's reach, valid faces, unit normals, finite UVs."""
    kind, size = kind_size
    obj = ObjectSpec(kind, Pose(), size, TextureSpec(frequency=1.0 / max(size)),
                     segments=segments, seed=seed, deform=deform)
    mesh = build_mesh(obj)
    v = np.asarray(mesh.vertices)
    assert np.isfinite(v).all() and len(mesh.faces) > 0
    assert int(np.asarray(mesh.faces).max()) < len(v)
    # within sum(size) of the origin (a torus: radius + tube); a taper widens by at most
    # 1 + |taper|, a twist keeps the distance to the axis, a bend keeps the arc length |y|
    # and each slice's offset r: at most |y| + r <= sqrt(2) |p|
    reach = sum(size) * (1 + abs(deform[2])) * (math.sqrt(2) if deform[1] else 1)
    assert np.linalg.norm(v, axis=1).max() <= reach * (1 + 1e-9)
    n = np.linalg.norm(np.asarray(mesh.vertex_normals), axis=1)
    assert np.all((np.abs(n - 1) < 1e-6) | (n == 0))
    assert np.isfinite(np.asarray(mesh.visual.uv)).all()


def _area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_every_letter_outline_is_simple_and_its_cap_covers_it():
    """The L, T and U outlines never cross themselves (a U's bars once overlapped for narrow
    letters with thick bars, and ear clipping looped forever): their caps' triangles are
    counter-clockwise and add up to the outline's area, over 3000 draws."""
    from scenes import extrusions

    for seed in range(3000):
        poly = extrusions._letter(np.random.default_rng(seed))
        tri = extrusions._ear_clip(poly)
        assert len(tri) == len(poly) - 2
        areas = [_area(poly[t]) for t in tri]
        assert min(areas) > 0 and sum(areas) == pytest.approx(_area(poly), rel=1e-9)


def test_ear_clipping_refuses_a_crossing_outline_instead_of_looping():
    from scenes import extrusions

    # the U whose bars overlapped (w = 0.84, a = 0.45): its notch turned inside out
    w, a = 0.8368, 0.4460
    folded = np.array([(0, 0), (w, 0), (w, 1), (w - a, 1), (w - a, a), (a, a), (a, 1), (0, 1)])
    with pytest.raises(ValueError, match="not a simple polygon"):
        extrusions._ear_clip(folded)
