"""Meshes: geometry exact where it should be, outward winding, textures and UVs."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from scenes.primitives import OPEN_KINDS, build_mesh, build_meshes, plane_equation
from scenes.spec import ObjectSpec, Pose, SceneSpec, TextureSpec
from scenes.textures import PIXELS_PER_CYCLE

_POSE = Pose(translation=(0.3, -0.2, 4.0), rotation_deg=(17.0, -33.0, 71.0))
_TEX = TextureSpec(frequency=20.0, seed=4)


def _signed_volume(mesh: trimesh.Trimesh) -> float:
    tri = mesh.vertices[mesh.faces]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)


def _closed(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Copy with the UV-seam duplicates merged, to check the geometry is closed."""
    merged = mesh.copy()
    merged.merge_vertices(merge_tex=True, merge_norm=True)
    return merged


@pytest.mark.parametrize("rotation", [(0.0, 0.0, 0.0), (30.0, 10.0, 0.0), (-80.0, 45.0, 170.0)])
def test_plane_vertices_satisfy_plane_equation(rotation) -> None:
    obj = ObjectSpec("plane", Pose((0.05, -0.3, 2.5), rotation), (3.0, 2.0), _TEX)
    mesh = build_mesh(obj)
    n, c = plane_equation(obj)
    assert mesh.faces.shape == (2, 3) and len(mesh.vertices) == 4
    assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(mesh.vertices @ n - c, 0.0, atol=1e-12)
    # the faces' winding normal is n (facing side), and the plane keeps its size
    np.testing.assert_allclose(mesh.face_normals, [n, n], atol=1e-12)
    edges = np.linalg.norm(np.diff(mesh.vertices[[0, 1, 2]], axis=0), axis=1)
    np.testing.assert_allclose(edges, [3.0, 2.0], rtol=1e-12)


def test_unrotated_plane_faces_the_camera() -> None:
    obj = ObjectSpec("plane", Pose((0.0, 0.0, 2.0)), (2.0, 1.0), _TEX)
    n, c = plane_equation(obj)
    assert n.tolist() == [0.0, 0.0, -1.0] and c == -2.0
    mesh = build_mesh(obj)
    assert sorted(map(tuple, mesh.vertices.tolist())) == [
        (-1.0, -0.5, 2.0), (-1.0, 0.5, 2.0), (1.0, -0.5, 2.0), (1.0, 0.5, 2.0)]
    # u grows with x, image row 0 (uv v = 1) at the top (smallest y)
    for (x, y, _), (u, v) in zip(mesh.vertices, mesh.visual.uv):
        assert (u, v) == ((x + 1.0) / 2.0, 1.0 - (y + 0.5))


def test_plane_equation_rejects_other_kinds() -> None:
    with pytest.raises(ValueError, match="kind 'plane', got 'box'"):
        plane_equation(ObjectSpec("box", _POSE, (1.0, 1.0, 1.0), _TEX, name="b"))


def test_sphere_vertices_lie_on_the_radius() -> None:
    obj = ObjectSpec("sphere", _POSE, (0.7,), _TEX, segments=32)
    mesh = build_mesh(obj)
    radii = np.linalg.norm(mesh.vertices - np.asarray(_POSE.translation), axis=1)
    np.testing.assert_allclose(radii, 0.7, rtol=1e-12)
    assert not (mesh.area_faces < 1e-12).any()  # no degenerate pole triangles


@pytest.mark.parametrize(("kind", "size", "volume", "rtol"), [
    ("box", (0.3, 0.5, 0.7), 0.3 * 0.5 * 0.7, 1e-12),
    ("sphere", (0.6,), 4 / 3 * math.pi * 0.6**3, 0.01),
    ("cylinder", (0.4, 0.9), math.pi * 0.4**2 * 0.9, 0.01),
])
def test_closed_kinds_are_watertight_with_outward_normals(kind, size, volume, rtol) -> None:
    mesh = build_mesh(ObjectSpec(kind, _POSE, size, _TEX, segments=64))
    merged = _closed(mesh)
    assert merged.is_watertight and merged.is_winding_consistent
    assert _signed_volume(mesh) == pytest.approx(volume, rel=rtol)  # > 0: outward
    assert not mesh.metadata["double_sided"]


def test_box_has_six_separately_textured_faces() -> None:
    mesh = build_mesh(ObjectSpec("box", Pose(), (1.0, 2.0, 3.0), _TEX))
    assert mesh.vertices.shape == (24, 3) and mesh.faces.shape == (12, 3)
    normals = np.unique(np.round(mesh.face_normals, 12), axis=0)
    assert len(normals) == 6
    corners = [set(mesh.faces[f]) | set(mesh.faces[f + 1]) for f in range(0, 12, 2)]
    assert all(len(c) == 4 for c in corners)  # each face's 4 vertices are its own
    assert len(set().union(*corners)) == 24


@pytest.mark.parametrize("kind", ["box", "cylinder"])
def test_atlas_charts_do_not_overlap_and_keep_metric_scale(kind: str) -> None:
    size = (0.3, 0.5, 0.7) if kind == "box" else (0.4, 0.9)
    tex = TextureSpec(kind="checker", frequency=20.0, seed=4)  # sampled at exactly 8 px/cycle
    mesh = build_mesh(ObjectSpec(kind, Pose(), size, tex, segments=16))
    uv = mesh.visual.uv
    assert uv.min() >= 0.0 and uv.max() <= 1.0
    w, h = mesh.visual.material.image.size
    # texture-space area (in m^2, via pixels at the texture's own sampling) equals surface area
    ppm = PIXELS_PER_CYCLE * tex.frequency
    tri = uv[mesh.faces] * [w / ppm, h / ppm]
    d1, d2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    uv_area = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]).sum()
    assert uv_area == pytest.approx(mesh.area, rel=0.03)
    # charts (box: 6 faces of 2 triangles; cylinder: side, top cap, bottom cap) are disjoint
    n = len(mesh.faces)
    bounds = [0, 2, 4, 6, 8, 10, 12] if kind == "box" else [0, n // 2, 3 * n // 4, n]
    boxes = [(uv[mesh.faces[a:b]].reshape(-1, 2).min(0), uv[mesh.faces[a:b]].reshape(-1, 2).max(0))
             for a, b in zip(bounds[:-1], bounds[1:])]
    for i, (lo_i, hi_i) in enumerate(boxes):
        for lo_j, hi_j in boxes[i + 1:]:
            assert (hi_i <= lo_j + 1e-12).any() or (hi_j <= lo_i + 1e-12).any()


def test_moebius_closes_with_a_half_twist() -> None:
    obj = ObjectSpec("moebius", Pose(), (1.0, 0.4), _TEX, segments=40)
    mesh = build_mesh(obj)
    assert mesh.metadata["double_sided"] and "moebius" in OPEN_KINDS
    merged = _closed(mesh)
    # one boundary loop of length ~ 2 x (2 pi R): the Moebius strip has a single edge
    boundary = trimesh.grouping.group_rows(merged.edges_sorted, require_count=1)
    assert 0 < len(boundary) == 2 * 40
    assert not merged.is_winding_consistent  # non-orientable
    centre_dist = np.linalg.norm(mesh.vertices[:, :2], axis=1)
    assert centre_dist.min() >= 1.0 - 0.2 - 1e-12 and centre_dist.max() <= 1.0 + 0.2 + 1e-12


def test_terrain_is_a_seeded_heightfield_within_amplitude() -> None:
    tex = TextureSpec(frequency=1.0)
    base = ObjectSpec("terrain", Pose((0.0, 1.5, 10.0)), (20.0, 10.0, 0.4), tex, segments=32,
                      seed=3)
    mesh = build_mesh(base)
    heights = 1.5 - mesh.vertices[:, 1]
    assert np.abs(heights).max() == pytest.approx(0.4)  # normalised to the amplitude
    assert mesh.vertices[:, 0].min() == -10.0 and mesh.vertices[:, 2].max() == 15.0
    assert (mesh.face_normals[:, 1] < 0).all()  # every face looks up (-y)
    again = build_mesh(base)
    other = build_mesh(ObjectSpec("terrain", base.pose, base.size, tex, segments=32, seed=4))
    np.testing.assert_array_equal(mesh.vertices, again.vertices)
    assert not np.array_equal(mesh.vertices, other.vertices)
    flat = build_mesh(ObjectSpec("terrain", base.pose, (20.0, 10.0, 0.0), tex, segments=32))
    assert (flat.vertices[:, 1] == 1.5).all()


@pytest.mark.parametrize("kind", ["plane", "box", "sphere", "cylinder", "moebius", "terrain"])
def test_every_kind_builds_a_textured_mesh(kind: str) -> None:
    size = {"plane": (1.0, 2.0), "box": (1.0, 1.0, 1.0), "sphere": (0.5,),
            "cylinder": (0.3, 1.0), "moebius": (1.0, 0.3), "terrain": (4.0, 4.0, 0.2)}[kind]
    mesh = build_mesh(ObjectSpec(kind, _POSE, size, TextureSpec(frequency=4.0), name="x",
                                 segments=12))
    assert isinstance(mesh.visual, trimesh.visual.TextureVisuals)
    assert mesh.visual.uv.shape == (len(mesh.vertices), 2)
    assert np.isfinite(mesh.vertices).all() and mesh.vertices.dtype == np.float64
    assert (mesh.visual.uv >= 0).all() and (mesh.visual.uv <= 1).all()
    image = np.asarray(mesh.visual.material.image)
    assert image.dtype == np.uint8 and image.shape[2] == 3
    assert list(mesh.visual.material.diffuse) == [255, 255, 255, 255]
    assert mesh.metadata == {"name": "x", "kind": kind, "double_sided": kind in OPEN_KINDS}


def test_build_meshes_keeps_order() -> None:
    objs = (ObjectSpec("sphere", _POSE, (0.5,), _TEX, segments=8),
            ObjectSpec("plane", _POSE, (1.0, 1.0), _TEX))
    meshes = build_meshes(SceneSpec("two", objs))
    assert [m.metadata["kind"] for m in meshes] == ["sphere", "plane"]
    with pytest.raises(TypeError, match="SceneSpec"):
        build_meshes(objs)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="ObjectSpec"):
        build_mesh("sphere")  # type: ignore[arg-type]


@pytest.mark.parametrize(("kind", "size", "degrees"), [
    ("sphere", (0.7,), 4.0), ("cylinder", (0.3, 0.8), 4.0), ("box", (0.3, 0.5, 0.7), 0.0),
    ("moebius", (1.0, 0.4), 4.0),
    ("terrain", (20.0, 10.0, 0.4), 12.0),  # coarse relief: the two weightings differ more
])
def test_vertex_normals_are_unit_and_close_to_trimesh(kind: str, size: tuple,
                                                      degrees: float) -> None:
    """Precomputed area-weighted normals agree with trimesh's angle-weighted ones."""
    mesh = build_mesh(ObjectSpec(kind, _POSE, size, _TEX, segments=24, seed=1))
    ours = mesh.vertex_normals
    ref = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).vertex_normals
    used = np.unique(mesh.faces)
    np.testing.assert_allclose(np.linalg.norm(ours[used], axis=1), 1.0, atol=1e-12)
    cos = np.einsum("ij,ij->i", ours[used], ref[used])
    assert cos.min() >= math.cos(math.radians(degrees)) - 1e-12
