"""Scenes and mesh lists turned into what :mod:`synth.render.renderer` uploads (no GL here).

Each mesh becomes interleaved float32 vertices (position, texture coordinate, baked
view-independent Lambert shade), uint32 faces, world-space vertex normals, its texture pixels and
whether its back faces may be culled (and, for lit scenes, its unshaded tint and material); depth-range checks against the rig happen before anything is drawn.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import trimesh

    from synth.camera.rig import StereoRig

__all__ = ["DEFAULT_LIGHT", "DISPLAY_GAMMA", "DepthRangeError", "Mesh", "as_meshes",
           "check_depth_range", "prepare_mesh", "texture_array"]

# Default lighting for bare mesh lists (SceneSpec brings its own).
DEFAULT_LIGHT = ((0.3, 0.5, 1.0), 0.7, 0.3)  # direction (light -> scene), intensity, ambient
DISPLAY_GAMMA = 2.2


@dataclass
class Mesh:
    name: str
    vertices: np.ndarray  # (n, 8) float32: world position, texcoord (s, t), shade (r, g, b)
    faces: np.ndarray  # (m, 3) uint32
    normals: np.ndarray  # (n, 3) float32 world-space unit vertex normals
    image: np.ndarray | None  # (h, w, 3 or 4) uint8 RGB(A), row 0 at t = 0
    closed: bool  # closed surface wound counter-clockwise seen from outside: cull back faces
    zmin: float
    zmax: float
    # lit scenes only (synth.render.lighting): the per-vertex colour the texture is multiplied
    # by without the baked shade, and the object's (specular, shininess, GGX roughness or 0 for
    # Blinn-Phong)
    tint: np.ndarray | None = None  # (n, 3) float32
    material: tuple[float, float, float] = (0.0, 32.0, 0.0)


def as_meshes(scene: Any) -> tuple[list[Mesh], tuple[float, float, float], dict]:
    """SceneSpec or mesh list -> shaded meshes, background colour, metadata.

    The meshes of a lit SceneSpec (``scene.is_lit()``) carry their object's material; bare mesh
    lists are matte.
    """
    import trimesh

    if hasattr(scene, "objects") and hasattr(scene, "light"):
        import scenes

        meshes = list(scenes.build_meshes(scene))
        names = [str(m.metadata.get("name") or f"{scene.name}[{i}]") for i, m in enumerate(meshes)]
        lt = scene.light
        light = (tuple(lt.direction), float(lt.intensity), float(lt.ambient))
        background = tuple(float(c) for c in scene.background)
        meta = {"scene": scene.name, "seed": scene.seed}
        materials = [(o.material.specular, o.material.shininess,
                      o.material.roughness if o.material.model == "ggx" else 0.0)
                     for o in scene.objects]
    elif isinstance(scene, Sequence) and not isinstance(scene, (str, bytes)):
        meshes = list(scene)
        names = [str(m.metadata.get("name", f"mesh[{i}]")) if isinstance(m, trimesh.Trimesh) else ""
                 for i, m in enumerate(meshes)]
        light, background, meta = DEFAULT_LIGHT, (0.0, 0.0, 0.0), {"scene": "meshes", "seed": None}
        materials = [(0.0, 32.0, 0.0)] * len(meshes)
    else:
        raise TypeError(
            f"scene must be a scenes.SceneSpec or a sequence of trimesh.Trimesh, got "
            f"{type(scene).__name__}; build one with scenes.get_preset(name)"
        )
    if not meshes:
        raise ValueError("the scene has no meshes; add at least one object")
    if len(background) != 3:
        raise ValueError(f"scene background must be 3 values in 0..1, got {background}")
    out = []
    lx = np.asarray(light[0], dtype=np.float64)
    if lx.shape != (3,) or not np.all(np.isfinite(lx)) or not np.any(lx):
        raise ValueError(f"light direction must be a finite non-zero 3-vector, got {light[0]}")
    to_light = -lx / np.linalg.norm(lx)
    for i, (m, name, material) in enumerate(zip(meshes, names, materials)):
        if not isinstance(m, trimesh.Trimesh):
            raise TypeError(f"mesh {i} must be a trimesh.Trimesh, got {type(m).__name__}")
        mesh = prepare_mesh(m, name, to_light, light[1], light[2])
        mesh.material = material
        out.append(mesh)
    return out, background, meta


def prepare_mesh(m: trimesh.Trimesh, name: str, to_light: np.ndarray, intensity: float,
                  ambient: float) -> Mesh:
    v = np.asarray(m.vertices, dtype=np.float64)
    f = np.asarray(m.faces)
    if len(f) == 0 or len(v) == 0:
        raise ValueError(
            f"object {name!r} has no triangles; drop it from the scene or give it faces")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"object {name!r} has non-finite vertex coordinates; fix its geometry")
    # View-independent Lambert. Open surfaces (metadata "double_sided", the default for
    # bare meshes: planes, a Moebius strip) have their normals turned toward the left
    # camera (the origin) so they are lit on the side we see; closed ones keep theirs.
    n = np.asarray(m.vertex_normals, dtype=np.float64)
    if m.metadata.get("double_sided", True):
        n = np.where((np.einsum("ij,ij->i", n, -v) < 0)[:, None], -n, n)
    shade = ambient + intensity * np.clip(n @ to_light, 0.0, None)
    # Textures hold display-encoded values: scale them by the encoded shading factor.
    mult = np.clip(shade, 0.0, None) ** (1.0 / DISPLAY_GAMMA)
    color = np.repeat(mult[:, None], 3, axis=1)
    tint = np.ones((len(v), 3))
    visual = m.visual
    uv = image = None
    if getattr(visual, "kind", None) == "texture":
        mat = visual.material
        image = getattr(mat, "image", None) or getattr(mat, "baseColorTexture", None)
        if visual.uv is not None and image is not None:
            uv = np.asarray(visual.uv, dtype=np.float64)
            image = texture_array(image)  # RGBA (RGBX) from PIL, arrays RGB(A) as they are
        else:
            image = None
            main = np.asarray(getattr(mat, "main_color", [255, 255, 255, 255]), dtype=np.float64)
            color *= main[:3] / 255.0
            tint *= main[:3] / 255.0
    elif getattr(visual, "kind", None) in ("vertex", "face"):
        color *= np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
        tint *= np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
    vertices = np.zeros((len(v), 8), dtype=np.float32)
    vertices[:, :3] = v
    if uv is not None:
        # UVs follow OpenGL (v = 1 is image row 0); images are uploaded row 0 first (t = 0)
        vertices[:, 3] = uv[:, 0]
        vertices[:, 4] = 1.0 - uv[:, 1]
    vertices[:, 5:] = color
    return Mesh(
        name=name,
        vertices=vertices,
        faces=np.ascontiguousarray(f, dtype=np.uint32),
        normals=np.asarray(m.vertex_normals, dtype=np.float32),
        image=image,
        closed=not m.metadata.get("double_sided", True),
        zmin=float(v[:, 2].min()),
        zmax=float(v[:, 2].max()),
        tint=tint.astype(np.float32),
    )


def texture_array(image: Any) -> np.ndarray:
    """A texture (PIL image or array) as a C-contiguous (h, w, 3 or 4) uint8 array.

    A PIL RGB image comes out as (h, w, 4), its RGB and the fourth byte PIL keeps beside them
    (RGBX: 255 from ``Image.fromarray``, 0 from ``Image.merge`` as in
    :func:`scenes.textures.texture_image`): the copy out of PIL costs what the 3-channel one
    does, and the upload then skips Mesa's RGB -> RGBA conversion (the texture is RGBA8 either
    way; shaders read ``.rgb`` only, so the fourth byte changes no output).
    """
    if hasattr(image, "mode") and hasattr(image, "convert"):  # a PIL image
        if image.mode not in ("RGB", "RGBA"):
            image = image.convert("RGB")
        if image.mode == "RGB":
            w, h = image.size
            return np.frombuffer(image.tobytes("raw", "RGBX"), np.uint8).reshape(h, w, 4)
    arr = np.asarray(image)
    if arr.ndim == 2:
        arr = np.repeat(arr[:, :, None], 3, axis=2)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4) or arr.dtype != np.uint8:
        raise ValueError(f"texture images must be (h, w, 3) uint8 RGB, got {arr.shape} "
                         f"{arr.dtype}; convert the image to 8-bit RGB")
    return np.ascontiguousarray(arr)


class DepthRangeError(ValueError):
    """An object seen by the rig reaches behind the camera or outside its ``[near, far]`` depths
    (a ``ValueError``; a dataset with ``redraw`` draws such a sample again)."""


def _frustum_planes(rig: StereoRig) -> list[tuple[np.ndarray, float]]:
    """``(n, c)`` with ``n . X + c >= 0`` inside: the four side planes of each view's pyramid
    through its pixels' outer edges (``-0.5`` to ``w - 0.5``, the same vertically), world frame."""
    w, h, fx, fy, cx, cy = rig.width, rig.height, rig.fx, rig.fy, rig.cx, rig.cy
    planes = []
    for centre in (0.0, rig.baseline):  # left camera at the origin, right at (baseline, 0, 0)
        for n in (np.array([fx, 0.0, cx + 0.5]), np.array([-fx, 0.0, w - 0.5 - cx]),
                  np.array([0.0, fy, cy + 0.5]), np.array([0.0, -fy, h - 0.5 - cy])):
            planes.append((n, -float(n[0]) * centre))
    return planes


def _clip(polygon: list[np.ndarray], n: np.ndarray, c: float) -> list[np.ndarray]:
    """Sutherland-Hodgman: the part of a convex polygon with ``n . X + c >= 0``."""
    out = []
    for i, p in enumerate(polygon):
        q = polygon[(i + 1) % len(polygon)]
        dp, dq = float(n @ p) + c, float(n @ q) + c
        if dp >= 0:
            out.append(p)
        if (dp >= 0) != (dq >= 0):
            out.append(p + (q - p) * (dp / (dp - dq)))
    return out


def _seen_z_range(m: Mesh, rig: StereoRig) -> tuple[float, float] | None:
    """The depth range of the part of ``m`` either view can see (inside either pyramid), from
    its triangles that leave ``[near, far]`` clipped to each view's side planes; None if that
    part is empty (the rest of ``m`` lies within ``[near, far]``)."""
    v = m.vertices[:, :3].astype(np.float64)
    tri = v[m.faces]
    z = tri[..., 2]
    leaving = tri[np.any((z < rig.near) | (z > rig.far), axis=1)]
    planes = _frustum_planes(rig)
    lo, hi = np.inf, -np.inf
    for t in leaving:
        for eye in (planes[:4], planes[4:]):
            poly = [t[0], t[1], t[2]]
            for n, c in eye:
                poly = _clip(poly, n, c)
                if not poly:
                    break
            if poly:
                zs = [p[2] for p in poly]
                lo, hi = min(lo, *zs), max(hi, *zs)
    return None if lo > hi else (lo, hi)


def check_depth_range(meshes: Sequence[Mesh], rig: StereoRig) -> None:
    """Raise :class:`DepthRangeError` if a mesh leaves ``(0, inf)`` or ``[near, far]`` where
    either view sees it.

    A mesh within ``[near, far]`` passes at once. An open one that leaves it (a room's ceiling
    behind a pitched rig) is clipped to the two views' pyramids (their side planes): only the part a view
    can see must lie within ``[near, far]``; what no view sees is never drawn, and GL's near and
    far clipping removes no visible surface, so the ground truth is that of the whole scene. A
    closed mesh (back faces culled) must lie wholly within the range, and a mesh wholly outside
    it fails even unseen (behind the cameras: a misplaced object).
    """
    for m in meshes:
        if m.zmin >= rig.near and m.zmax <= rig.far:
            continue
        # a closed mesh must lie wholly in range: its back faces are culled, which is exact only
        # with both cameras outside it (docs/ground-truth.md)
        seen = (m.zmin, m.zmax) if m.closed else _seen_z_range(m, rig)
        if seen is None:
            z = m.vertices[:, 2]
            if np.any((z >= rig.near) & (z <= rig.far)):
                continue  # what leaves the range is out of view, the rest within it
            seen = (m.zmin, m.zmax)  # wholly out of range (and of view): a misplaced object
        if seen[0] <= 0:
            raise DepthRangeError(
                f"object {m.name!r} reaches z={seen[0]:.4g} <= 0 in view, behind the left camera "
                f"(world frame = left camera, z forward); move it in front (z > near={rig.near})"
            )
        if seen[0] < rig.near or seen[1] > rig.far:
            raise DepthRangeError(
                f"object {m.name!r} spans z in [{seen[0]:.4g}, {seen[1]:.4g}] in view, outside "
                f"the rig's [near, far] = [{rig.near}, {rig.far}]; move the object or change the "
                "rig's near/far"
            )
