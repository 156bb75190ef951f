"""Property tests of mesh building: the fast forms compute numpy's plain forms' bits."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from scenes.primitives import _cross, _vertex_normals, build_mesh
from scenes.spec import ObjectSpec, Pose, TextureSpec

_coordinates = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


def reference_vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, plainly: ``np.cross``, one bincount per axis,
    ``np.linalg.norm``. ``_vertex_normals`` computes the same bits in fewer numpy calls."""
    tri = vertices[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normals = np.zeros_like(vertices)
    for axis in range(3):
        normals[:, axis] = np.bincount(faces.T.ravel(), np.tile(face_n[:, axis], 3),
                                       minlength=len(vertices))
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    np.divide(normals, length, out=normals, where=length > 0)
    return normals


@pytest.mark.parametrize(("kind", "size"), [
    ("plane", (2.0, 1.0)), ("box", (0.3, 0.5, 0.7)), ("sphere", (0.7,)),
    ("cylinder", (0.3, 0.8)), ("moebius", (1.0, 0.4)), ("terrain", (20.0, 10.0, 0.4)),
    ("fence", (2.0, 1.5, 0.3, 0.05)), ("grid", (2.0, 1.5, 0.3, 0.05)),
])
def test_vertex_normals_bits_equal_the_reference(kind: str, size: tuple) -> None:
    pose = Pose(translation=(0.2, -0.1, 3.0), rotation_deg=(10.0, 25.0, -5.0))
    mesh = build_mesh(ObjectSpec(kind, pose, size, TextureSpec(frequency=4.0), segments=24,
                                 seed=1))
    vertices, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    got = _vertex_normals(vertices, faces)
    assert got.tobytes() == reference_vertex_normals(vertices, faces).tobytes()
    assert got.tobytes() == np.asarray(mesh.vertex_normals).tobytes()  # what the mesh holds


@st.composite
def _meshes(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (some repeated: degenerate faces) and faces (some vertices in none)."""
    n = draw(st.integers(3, 24))
    vertices = draw(hnp.arrays(np.float64, (n, 3), elements=_coordinates))
    faces = draw(hnp.arrays(np.int64, (draw(st.integers(1, 40)), 3),
                            elements=st.integers(0, n - 1)))
    return vertices, faces


@given(_meshes())
def test_random_vertex_normals_bits_equal_the_reference(mesh) -> None:
    """Hand-picked examples: the meshes of every kind above."""
    vertices, faces = mesh
    got = _vertex_normals(vertices, faces)
    assert got.tobytes() == reference_vertex_normals(vertices, faces).tobytes()


@given(st.integers(0, 20).flatmap(
    lambda n: st.tuples(*[hnp.arrays(np.float64, (n, 3), elements=_coordinates)] * 2)),
    hnp.arrays(np.float64, (2, 3), elements=_coordinates))
def test_cross_bits_equal_numpy_cross(rows, pair) -> None:
    """Rows of (N, 3) arrays (face normals) and single 3-vectors (quads' axes)."""
    a, b = rows
    assert _cross(a, b).tobytes() == np.cross(a, b).tobytes()
    assert _cross(pair[0], pair[1]).tobytes() == np.cross(pair[0], pair[1]).tobytes()
