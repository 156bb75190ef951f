"""The only GL module: backend choice, context lifetime, colour and exact depth.

Colour comes from pyrender (4x MSAA, mipmapped textures) with a view-independent
Lambert shading baked into per-vertex colours, so a surface point has the same
colour in both views. Ground truth comes from a separate pass of our own:
no multisampling, a 32-bit float colour target that receives the camera-space
depth ``Z`` interpolated (perspective-correctly) at each pixel centre, and a
32-bit float depth buffer. See ``docs/ground-truth.md`` for why.

pyrender and PyOpenGL are imported lazily: ``PYOPENGL_PLATFORM`` must be set
before the first ``import OpenGL`` and cannot change afterwards.
"""

from __future__ import annotations

import ctypes
import functools
import os
import subprocess
import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Iterator, Sequence

import numpy as np

if TYPE_CHECKING:
    import trimesh

    from synth.rig import StereoRig

__all__ = ["GLBackendError", "Renderer", "ViewRender", "BACKENDS"]

#: Backends in the order ``backend="auto"`` tries them.
BACKENDS = ("egl", "osmesa")
_DEBIAN_FIX = {
    "egl": "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri",
    "osmesa": "apt-get install libosmesa6",
}
# Default lighting for bare mesh lists (SceneSpec brings its own).
_DEFAULT_LIGHT = ((0.3, 0.5, 1.0), 0.7, 0.3)  # direction (light -> scene), intensity, ambient
_DISPLAY_GAMMA = 2.2


class GLBackendError(RuntimeError):
    """No OpenGL backend could be started (the message names each one tried and the fix)."""


@dataclass(frozen=True)
class ViewRender:
    """One rendered view.

    Attributes
    ----------
    color : (H, W, 3) uint8 array
        RGB image, row 0 at the top.
    depth : (H, W) float32 array
        Camera-space depth ``Z`` (metres, along the optical axis) of the
        surface seen through each pixel centre; ``inf`` where there is none.
    """

    color: np.ndarray
    depth: np.ndarray


# ---------------------------------------------------------------------------- backends
_PROBE = """
import os, sys
b = sys.argv[1]
if b == "egl":
    from pyrender.platforms.egl import EGLPlatform, get_device_by_index
    p = EGLPlatform(8, 8, device=get_device_by_index(0))
else:
    from pyrender.platforms.osmesa import OSMesaPlatform
    p = OSMesaPlatform(8, 8)
p.init_context()
p.make_current()
from OpenGL import GL
print(GL.glGetString(GL.GL_RENDERER).decode())
p.delete_context()
"""


@functools.cache
def _probe(backend: str) -> str | None:
    """Try ``backend`` in a subprocess; ``None`` if it starts, else the error text."""
    env = dict(os.environ, PYOPENGL_PLATFORM=backend)
    try:
        out = subprocess.run(
            [sys.executable, "-c", _PROBE, backend],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:  # pragma: no cover - defensive
        return f"probe failed to run: {exc}"
    if out.returncode == 0:
        return None
    lines = [ln for ln in (out.stderr or out.stdout).strip().splitlines() if ln.strip()]
    return lines[-1] if lines else f"exit status {out.returncode}"


def _platform_in_use() -> str | None:
    """The PyOpenGL platform this process is locked to, or ``None`` if not chosen yet."""
    mod = sys.modules.get("OpenGL.platform")
    if mod is None or getattr(mod, "PLATFORM", None) is None:
        return None
    name = type(mod.PLATFORM).__name__.lower()
    for b in BACKENDS:
        if b in name:
            return b
    return name.replace("platform", "") or name


def _choose_backend(backend: str) -> str:
    """Pick the backend to start in this process (probing before any OpenGL import)."""
    wanted = list(BACKENDS) if backend == "auto" else [backend]
    locked = _platform_in_use()
    if locked is not None:
        if locked in wanted:
            return locked
        hint = (f"use backend={locked!r} or 'auto', or" if locked in BACKENDS
                else "stereoforge supports only 'egl' and 'osmesa':")
        raise GLBackendError(
            f"backend={backend!r} is not available: PyOpenGL was already imported in this "
            f"process with the {locked!r} platform and cannot switch; {hint} create the Renderer "
            "in a fresh process before anything imports OpenGL or pyrender (PyOpenGL reads "
            "PYOPENGL_PLATFORM once, at import)"
        )
    failures = []
    for b in wanted:
        err = _probe(b)
        if err is None:
            return b
        failures.append(f"  {b}: {err}\n    fix (Debian): {_DEBIAN_FIX[b]}")
    raise GLBackendError(
        "no OpenGL backend could start; tried:\n" + "\n".join(failures)
    )


# ---------------------------------------------------------------------------- geometry
def _projection(rig: StereoRig) -> np.ndarray:
    """OpenGL projection of the OpenCV-convention pinhole (pixel centres at integers)."""
    w, h, n, f = rig.width, rig.height, rig.near, rig.far
    P = np.zeros((4, 4))
    P[0, 0] = 2.0 * rig.fx / w
    P[0, 2] = 1.0 - 2.0 * (rig.cx + 0.5) / w
    P[1, 1] = 2.0 * rig.fy / h
    P[1, 2] = 2.0 * (rig.cy + 0.5) / h - 1.0
    P[2, 2] = -(f + n) / (f - n)
    P[2, 3] = -2.0 * f * n / (f - n)
    P[3, 2] = -1.0
    return P


def _camera_pose(rig: StereoRig, eye: str) -> np.ndarray:
    """Pose (camera -> world) of the GL camera: OpenCV axes flipped to OpenGL's."""
    pose = np.diag([1.0, -1.0, -1.0, 1.0])
    if eye == "right":
        pose[0, 3] = rig.baseline
    return pose


@dataclass
class _Mesh:
    name: str
    positions: np.ndarray  # (n, 3) float32, world
    faces: np.ndarray  # (m, 3) uint32
    uv: np.ndarray | None
    image: Any  # PIL image or None
    color_mult: np.ndarray  # (n, 4) float32
    zmin: float
    zmax: float


def _as_meshes(scene: Any) -> tuple[list[_Mesh], tuple[float, float, float], dict]:
    """SceneSpec or mesh list -> shaded meshes, background colour, metadata."""
    import trimesh

    if hasattr(scene, "objects") and hasattr(scene, "light"):
        import scenes

        meshes = list(scenes.build_meshes(scene))
        names = [str(m.metadata.get("name") or f"{scene.name}[{i}]") for i, m in enumerate(meshes)]
        lt = scene.light
        light = (tuple(lt.direction), float(lt.intensity), float(lt.ambient))
        background = tuple(float(c) for c in scene.background)
        meta = {"scene": scene.name, "seed": scene.seed}
    elif isinstance(scene, Sequence) and not isinstance(scene, (str, bytes)):
        meshes = list(scene)
        names = [str(m.metadata.get("name", f"mesh[{i}]")) if isinstance(m, trimesh.Trimesh) else ""
                 for i, m in enumerate(meshes)]
        light, background, meta = _DEFAULT_LIGHT, (0.0, 0.0, 0.0), {"scene": "meshes", "seed": None}
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
    for i, (m, name) in enumerate(zip(meshes, names)):
        if not isinstance(m, trimesh.Trimesh):
            raise TypeError(f"mesh {i} must be a trimesh.Trimesh, got {type(m).__name__}")
        out.append(_prepare_mesh(m, name, to_light, light[1], light[2]))
    return out, background, meta


def _prepare_mesh(m: trimesh.Trimesh, name: str, to_light: np.ndarray, intensity: float,
                  ambient: float) -> _Mesh:
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
    mult = np.clip(shade, 0.0, None) ** (1.0 / _DISPLAY_GAMMA)
    color = np.ones((len(v), 4))
    color[:, :3] = mult[:, None]
    visual = m.visual
    uv = image = None
    if getattr(visual, "kind", None) == "texture":
        mat = visual.material
        image = getattr(mat, "image", None) or getattr(mat, "baseColorTexture", None)
        if visual.uv is not None and image is not None:
            uv = np.asarray(visual.uv, dtype=np.float32)
        else:
            image = None
            main = np.asarray(getattr(mat, "main_color", [255, 255, 255, 255]), dtype=np.float64)
            color[:, :3] *= main[:3] / 255.0
    elif getattr(visual, "kind", None) in ("vertex", "face"):
        color[:, :3] *= np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
    return _Mesh(
        name=name,
        positions=np.ascontiguousarray(v, dtype=np.float32),
        faces=np.ascontiguousarray(f, dtype=np.uint32),
        uv=uv,
        image=image,
        color_mult=color.astype(np.float32),
        zmin=float(v[:, 2].min()),
        zmax=float(v[:, 2].max()),
    )


def _check_depth_range(meshes: Sequence[_Mesh], rig: StereoRig) -> None:
    for m in meshes:
        if m.zmin <= 0:
            raise ValueError(
                f"object {m.name!r} reaches z={m.zmin:.4g} <= 0, behind the left camera "
                f"(world frame = left camera, z forward); move it in front (z > near={rig.near})"
            )
        if m.zmin < rig.near or m.zmax > rig.far:
            raise ValueError(
                f"object {m.name!r} spans z in [{m.zmin:.4g}, {m.zmax:.4g}], outside the rig's "
                f"[near, far] = [{rig.near}, {rig.far}]; move the object or change the rig's "
                "near/far"
            )


# ---------------------------------------------------------------------------- GL passes
_GT_VERT = """#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 PV;
out float z_cam;
void main() {
    gl_Position = PV * vec4(position, 1.0);
    z_cam = position.z;  // both cameras share the world's orientation: Z_cam = Z_world
}
"""
_GT_FRAG = """#version 330 core
in float z_cam;
uniform float inv_far;
layout(location = 0) out float out_z;
void main() {
    out_z = z_cam;
    gl_FragDepth = z_cam * inv_far;  // linear depth: uniform float32 resolution
}
"""


class _DepthPass:
    """Single-sample float32 pass writing camera-space Z at pixel centres."""

    def __init__(self, width: int, height: int) -> None:
        from OpenGL import GL
        from OpenGL.GL import shaders

        self.program = shaders.compileProgram(
            shaders.compileShader(_GT_VERT, GL.GL_VERTEX_SHADER),
            shaders.compileShader(_GT_FRAG, GL.GL_FRAGMENT_SHADER),
            validate=False,
        )
        self.loc_pv = GL.glGetUniformLocation(self.program, "PV")
        self.loc_far = GL.glGetUniformLocation(self.program, "inv_far")
        self.rb_color, self.rb_depth = GL.glGenRenderbuffers(2)
        self.fbo = GL.glGenFramebuffers(1)
        self.resize(width, height)

    def resize(self, width: int, height: int) -> None:
        """(Re)allocate the R32F colour and DEPTH_COMPONENT32F attachments."""
        from OpenGL import GL

        self.w, self.h = width, height
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, self.rb_color)
        GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_R32F, width, height)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, self.rb_depth)
        GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_DEPTH_COMPONENT32F, width, height)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, 0)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fbo)
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0,
                                     GL.GL_RENDERBUFFER, self.rb_color)
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT,
                                     GL.GL_RENDERBUFFER, self.rb_depth)
        status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        if status != GL.GL_FRAMEBUFFER_COMPLETE:
            raise GLBackendError(f"float32 depth framebuffer incomplete (status 0x{status:x})")

    def upload(self, meshes: Sequence[_Mesh]) -> tuple[int, list[int], int]:
        """All meshes in one VAO: one draw call per view (llvmpipe's per-draw cost dominates)."""
        from OpenGL import GL

        positions = np.concatenate([m.positions for m in meshes])
        offsets = np.cumsum([0] + [len(m.positions) for m in meshes[:-1]])
        faces = np.concatenate([m.faces + np.uint32(o) for m, o in zip(meshes, offsets)])
        vao = GL.glGenVertexArrays(1)
        vbo, ebo = GL.glGenBuffers(2)
        GL.glBindVertexArray(vao)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, vbo)
        GL.glBufferData(GL.GL_ARRAY_BUFFER, positions.nbytes, positions, GL.GL_STATIC_DRAW)
        GL.glEnableVertexAttribArray(0)
        GL.glVertexAttribPointer(0, 3, GL.GL_FLOAT, GL.GL_FALSE, 12, ctypes.c_void_p(0))
        GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, ebo)
        GL.glBufferData(GL.GL_ELEMENT_ARRAY_BUFFER, faces.nbytes, faces, GL.GL_STATIC_DRAW)
        GL.glBindVertexArray(0)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
        return vao, [vbo, ebo], int(faces.size)

    def release(self, upload: tuple[int, list[int], int]) -> None:
        from OpenGL import GL

        vao, bufs, _ = upload
        GL.glDeleteVertexArrays(1, [vao])
        GL.glDeleteBuffers(len(bufs), bufs)

    def render(self, upload: tuple[int, list[int], int], pv: np.ndarray, far: float) -> np.ndarray:
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fbo)
        GL.glViewport(0, 0, self.w, self.h)
        GL.glDisable(GL.GL_MULTISAMPLE)
        GL.glDisable(GL.GL_BLEND)
        GL.glDisable(GL.GL_CULL_FACE)
        GL.glPolygonMode(GL.GL_FRONT_AND_BACK, GL.GL_FILL)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glDepthFunc(GL.GL_LESS)
        GL.glDepthRange(0.0, 1.0)
        GL.glClearBufferfv(GL.GL_COLOR, 0, np.array([np.inf, 0, 0, 0], dtype=np.float32))
        GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
        GL.glUseProgram(self.program)
        GL.glUniformMatrix4fv(self.loc_pv, 1, GL.GL_TRUE, pv.astype(np.float32))
        GL.glUniform1f(self.loc_far, 1.0 / far)
        vao, _, count = upload
        GL.glBindVertexArray(vao)
        GL.glDrawElements(GL.GL_TRIANGLES, count, GL.GL_UNSIGNED_INT, ctypes.c_void_p(0))
        GL.glBindVertexArray(0)
        GL.glUseProgram(0)
        GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0)
        buf = GL.glReadPixels(0, 0, self.w, self.h, GL.GL_RED, GL.GL_FLOAT)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        z = np.frombuffer(bytes(buf) if not isinstance(buf, np.ndarray) else buf.tobytes(),
                          dtype=np.float32).reshape(self.h, self.w)
        return np.ascontiguousarray(z[::-1])  # GL rows run bottom-up

    def delete(self) -> None:
        from OpenGL import GL

        GL.glDeleteFramebuffers(1, [self.fbo])
        GL.glDeleteRenderbuffers(2, [self.rb_color, self.rb_depth])
        GL.glDeleteProgram(self.program)


@dataclass
class _Upload:
    """GL resources of one scene: pyrender scene for colour, our VAOs for depth."""

    meshes: list[_Mesh]
    pr_scene: Any
    camera: Any
    camera_node: Any
    pr_meshes: list[Any]
    textures: list[Any]
    gt: tuple[int, list[int], int] | None
    meta: dict = field(default_factory=dict)


def _camera_class() -> type:
    import pyrender

    class _CVCamera(pyrender.Camera):
        """pyrender camera with a fixed, exact OpenCV-convention projection."""

        def __init__(self, P: np.ndarray, near: float, far: float) -> None:
            super().__init__(znear=near, zfar=far)
            self.P = P

        def get_projection_matrix(self, width: int | None = None,
                                  height: int | None = None) -> np.ndarray:
            return self.P

    return _CVCamera


def _color_renderer_class() -> type:
    import pyrender
    from OpenGL import GL

    class _ColorRenderer(pyrender.Renderer):
        """pyrender's renderer without its depth readback.

        pyrender 0.1.45 reads and linearises its 24-bit MSAA depth after every
        render; we never use it (our depth pass is exact), so the read-out keeps
        only the MSAA colour resolve. Overrides a private method of the pinned
        pyrender version.
        """

        def _read_main_framebuffer(self, scene: Any, flags: Any) -> tuple[np.ndarray, None]:
            w, h = self._main_fb_dims
            GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self._main_fb_ms)
            GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, self._main_fb)
            GL.glBlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL.GL_COLOR_BUFFER_BIT, GL.GL_NEAREST)
            GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self._main_fb)
            buf = GL.glReadPixels(0, 0, w, h, GL.GL_RGB, GL.GL_UNSIGNED_BYTE)
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
            color = np.frombuffer(buf, dtype=np.uint8).reshape(h, w, 3)
            return np.ascontiguousarray(color[::-1]), None  # GL rows run bottom-up

    return _ColorRenderer


# ---------------------------------------------------------------------------- Renderer
class Renderer:
    """An offscreen OpenGL context that renders views with exact depth.

    One GL context lives as long as the renderer and is reused by every render.
    Use it as a context manager (or call :meth:`close`).

    Parameters
    ----------
    width, height : int
        Initial framebuffer size in pixels. A rig of another size may be
        rendered: the framebuffers are reallocated to it (cheap, but keep one
        size per renderer in a loop).
    backend : {"auto", "egl", "osmesa"}
        ``"auto"`` tries EGL, then OSMesa. PyOpenGL binds one platform per
        process at its first import, so all renderers of a process share it.

    Raises
    ------
    GLBackendError
        If no requested backend starts (the message names each backend tried,
        its error and the Debian package that fixes it).

    Examples
    --------
    >>> import trimesh
    >>> from synth.rig import StereoRig
    >>> quad = trimesh.Trimesh([[-1, -1, 2], [1, -1, 2], [1, 1, 2], [-1, 1, 2]],
    ...                        [[0, 1, 2], [0, 2, 3]], process=False)
    >>> rig = StereoRig.default(32, 24)
    >>> with Renderer(32, 24) as r:  # doctest: +SKIP
    ...     view = r.render_view([quad], rig, eye="left")
    >>> float(view.depth[12, 16])  # doctest: +SKIP
    2.0
    """

    def __init__(self, width: int, height: int, *, backend: str = "auto") -> None:
        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
                raise ValueError(f"{name} must be a positive int, got {value!r}")
        if backend not in ("auto",) + BACKENDS:
            raise ValueError(
                f"backend must be one of 'auto', 'egl', 'osmesa', got {backend!r}; "
                "use 'auto' to try EGL then OSMesa"
            )
        self.width, self.height = int(width), int(height)
        self._closed = True
        self._held: dict[int, tuple[Any, _Upload]] = {}
        self.backend = _choose_backend(backend)
        os.environ["PYOPENGL_PLATFORM"] = self.backend  # read once, by PyOpenGL's first import
        try:
            self._platform = self._make_platform()
            self._platform.init_context()
            self._platform.make_current()
            from OpenGL import GL

            GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
            GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
            self._pr = _color_renderer_class()(self.width, self.height)
            self._depth = _DepthPass(self.width, self.height)
            self.gl_renderer = GL.glGetString(GL.GL_RENDERER).decode()
            self.gl_version = GL.glGetString(GL.GL_VERSION).decode()
        except GLBackendError:
            raise
        except Exception as exc:
            raise GLBackendError(
                f"the {self.backend} backend failed to start in this process: "
                f"{type(exc).__name__}: {exc}\n  fix (Debian): {_DEBIAN_FIX[self.backend]}"
            ) from exc
        self._camera_cls = _camera_class()
        self._closed = False

    def _make_platform(self) -> Any:
        if self.backend == "egl":
            from pyrender.platforms.egl import EGLPlatform, get_device_by_index

            return EGLPlatform(self.width, self.height, device=get_device_by_index(0))
        from pyrender.platforms.osmesa import OSMesaPlatform

        return OSMesaPlatform(self.width, self.height)

    # -------------------------------------------------------------- lifetime
    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Free every GL resource and the context (idempotent)."""
        if self._closed:
            return
        self._platform.make_current()
        for _, up in list(self._held.values()):
            self._release(up)
        self._held.clear()
        self._depth.delete()
        self._pr.delete()
        self._destroy_context()
        self._closed = True

    def _destroy_context(self) -> None:
        """Destroy only our context.

        pyrender's ``EGLPlatform.delete_context`` also calls ``eglTerminate`` on
        the display, which every EGL context of the process shares: it would
        break the other open renderers. The display stays initialised for the
        life of the process.
        """
        p = self._platform
        if self.backend == "egl":
            from OpenGL import EGL

            EGL.eglMakeCurrent(p._egl_display, EGL.EGL_NO_SURFACE, EGL.EGL_NO_SURFACE,
                               EGL.EGL_NO_CONTEXT)
            EGL.eglDestroyContext(p._egl_display, p._egl_context)
            p._egl_context = p._egl_display = None  # makes pyrender's __del__ a no-op
        else:
            from OpenGL.osmesa import OSMesaDestroyContext

            OSMesaDestroyContext(p._context)
            p._context = None
            p.delete_context = lambda: None  # pyrender's __del__ would destroy it again

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this Renderer is closed; open a new one (use it as a `with` block)")

    # -------------------------------------------------------------- uploads
    def _upload(self, scene: Any) -> _Upload:
        import pyrender

        meshes, background, meta = _as_meshes(scene)
        self._platform.make_current()
        pr_scene = pyrender.Scene(bg_color=[*background, 1.0], ambient_light=[0.0, 0.0, 0.0])
        textures: dict[int, Any] = {}
        pr_meshes = []
        for m in meshes:
            tex = None
            if m.image is not None:
                key = id(m.image)
                if key not in textures:
                    src = np.asarray(m.image.convert("RGB"), dtype=np.uint8)
                    textures[key] = pyrender.Texture(source=src, source_channels="RGB")
                tex = textures[key]
            mat = pyrender.MetallicRoughnessMaterial(
                baseColorFactor=[1.0, 1.0, 1.0, 1.0], baseColorTexture=tex,
                metallicFactor=0.0, roughnessFactor=1.0, doubleSided=True,
            )
            prim = pyrender.Primitive(
                positions=m.positions, indices=m.faces, texcoord_0=m.uv,
                color_0=m.color_mult, material=mat, mode=pyrender.GLTF.TRIANGLES,
            )
            mesh = pyrender.Mesh([prim], name=m.name)
            pr_meshes.append(mesh)
            pr_scene.add(mesh)
        camera = self._camera_cls(np.eye(4), 0.1, 100.0)
        node = pr_scene.add(camera, pose=np.eye(4))
        gt = self._depth.upload(meshes)
        return _Upload(meshes, pr_scene, camera, node, pr_meshes, list(textures.values()), gt, meta)

    def _release(self, up: _Upload) -> None:
        self._platform.make_current()
        for mesh in up.pr_meshes:
            for p in mesh.primitives:
                p.delete()
        for tex in up.textures:
            tex.delete()
        if up.gt is not None:
            self._depth.release(up.gt)
            up.gt = None

    @contextmanager
    def uploaded(self, scene: Any) -> Iterator[dict]:
        """Keep ``scene`` on the GPU for the ``with`` block; release it after.

        Renders of the same scene object inside the block reuse its meshes and
        textures (``render_pair`` renders left and right this way). Yields the
        scene's metadata (name, seed).
        """
        self._check_open()
        key = id(scene)
        if key in self._held:
            yield dict(self._held[key][1].meta)
            return
        up = self._upload(scene)
        self._held[key] = (scene, up)  # keeps `scene` alive so its id is not reused
        try:
            yield dict(up.meta)
        finally:
            del self._held[key]
            self._release(up)

    # -------------------------------------------------------------- render
    def render_view(self, scene: Any, rig: StereoRig, *, eye: str) -> ViewRender:
        """Render one view of ``scene`` through ``rig``.

        Parameters
        ----------
        scene : scenes.SceneSpec or sequence of trimesh.Trimesh
            Meshes in world coordinates (= left camera frame, OpenCV axes).
        rig : StereoRig
            Intrinsics, baseline and image size of the view.
        eye : {"left", "right"}
            The right camera sits at ``(rig.baseline, 0, 0)``.

        Returns
        -------
        ViewRender
            ``color`` (H, W, 3) uint8 and ``depth`` (H, W) float32 ``Z`` with
            ``inf`` where the pixel centre's ray hits nothing.

        Raises
        ------
        ValueError
            If an object lies behind the camera or outside ``[near, far]``.
        """
        from synth.rig import StereoRig

        self._check_open()
        if not isinstance(rig, StereoRig):
            raise TypeError(f"rig must be a StereoRig, got {type(rig).__name__}")
        if eye not in ("left", "right"):
            raise ValueError(f"eye must be 'left' or 'right', got {eye!r}")
        with self.uploaded(scene):
            up = self._held[id(scene)][1]
            _check_depth_range(up.meshes, rig)
            return self._render(up, rig, eye)

    def _render(self, up: _Upload, rig: StereoRig, eye: str) -> ViewRender:
        import pyrender

        self._platform.make_current()
        if (rig.width, rig.height) != (self.width, self.height):
            self.width, self.height = rig.width, rig.height
            self._pr.viewport_width, self._pr.viewport_height = rig.width, rig.height
            self._depth.resize(rig.width, rig.height)
        P = _projection(rig)
        pose = _camera_pose(rig, eye)
        up.camera.P = P
        up.camera.znear, up.camera.zfar = rig.near, rig.far
        up.pr_scene.set_pose(up.camera_node, pose)
        flags = pyrender.RenderFlags.OFFSCREEN | pyrender.RenderFlags.FLAT
        color, _ = self._pr.render(up.pr_scene, flags)
        depth = self._depth.render(up.gt, P @ np.linalg.inv(pose), rig.far)
        return ViewRender(color=color, depth=depth)
