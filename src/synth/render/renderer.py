"""The only GL module: context lifetime, colour and exact depth.

Both passes are our own shader programs in one GL context (made by
:mod:`synth.render.context` from PyOpenGL's EGL or OSMesa bindings). Colour: a view-independent Lambert shading baked into
per-vertex colours times a mipmapped texture, 4x MSAA resolved to the pixel
average, so a surface point has the same colour in both views. Ground truth:
no multisampling, a 32-bit float colour target that receives the camera-space
depth ``Z`` interpolated (perspective-correctly) at each pixel centre, and a
32-bit float depth buffer. See ``docs/ground-truth.md`` for why.

PyOpenGL is imported lazily: ``PYOPENGL_PLATFORM`` must be set before the first
``import OpenGL`` and cannot change afterwards. Backend choice lives in
:mod:`synth.render.backend`, context creation in :mod:`synth.render.context`, scene-to-mesh
preparation in :mod:`synth.render.meshes`.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from synth.render.backend import (
    BACKENDS,
    DEBIAN_FIX,
    GLBackendError,
    check_backend_name,
    check_threads,
    choose_backend,
    driver_threads,
    refuse_late_threads,
    resolve_backend,
)
from synth.render.context import open_context
from synth.render.meshes import Mesh, as_meshes, check_depth_range

if TYPE_CHECKING:
    from synth.rig import StereoRig

__all__ = ["GLBackendError", "Renderer", "ViewRender", "BACKENDS", "resolve_backend"]


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


# ---------------------------------------------------------------------------- GL passes
#: Samples per pixel of the colour pass (its resolve averages them: area antialiasing).
_MSAA_SAMPLES = 4
# Interleaved vertex layout shared by both passes: position (3), texcoord (2), shade (3).
_STRIDE = 8 * 4

_COLOR_VERT = """#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec2 texcoord;
layout(location = 2) in vec3 shade;
uniform mat4 PV;
out vec2 uv;
out vec3 mult;
void main() {
    gl_Position = PV * vec4(position, 1.0);
    uv = texcoord;
    mult = shade;
}
"""
_COLOR_FRAG = """#version 330 core
in vec2 uv;
in vec3 mult;
uniform sampler2D tex;
layout(location = 0) out vec4 out_color;
void main() {
    out_color = vec4(clamp(texture(tex, uv).rgb * mult, 0.0, 1.0), 1.0);
}
"""
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


def _program(vert: str, frag: str) -> int:
    from OpenGL import GL
    from OpenGL.GL import shaders

    return shaders.compileProgram(
        shaders.compileShader(vert, GL.GL_VERTEX_SHADER),
        shaders.compileShader(frag, GL.GL_FRAGMENT_SHADER),
        validate=False,
    )


def _framebuffer(attachments: Sequence[tuple[int, int]], width: int, height: int,
                 samples: int, what: str) -> tuple[int, list[int]]:
    """A framebuffer with one renderbuffer per ``(attachment point, internal format)``."""
    from OpenGL import GL

    fbo = GL.glGenFramebuffers(1)
    rbs = [int(r) for r in np.atleast_1d(GL.glGenRenderbuffers(len(attachments)))]
    GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
    for rb, (point, fmt) in zip(rbs, attachments):
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, rb)
        if samples > 1:
            GL.glRenderbufferStorageMultisample(GL.GL_RENDERBUFFER, samples, fmt, width, height)
        else:
            GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, fmt, width, height)
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, point, GL.GL_RENDERBUFFER, rb)
    GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, 0)
    status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
    GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
    if status != GL.GL_FRAMEBUFFER_COMPLETE:
        raise GLBackendError(f"{what} framebuffer incomplete (status 0x{status:x})")
    return int(fbo), rbs


def _delete_framebuffer(fb: tuple[int, list[int]]) -> None:
    from OpenGL import GL

    GL.glDeleteFramebuffers(1, [fb[0]])
    GL.glDeleteRenderbuffers(len(fb[1]), fb[1])


def _set_culling(cull: bool) -> None:
    """Back-face culling on (closed meshes) or off (open, double-sided surfaces).

    Culling a closed, outward-wound mesh changes no pixel: both cameras are
    outside it (every mesh lies at ``z >= near > 0``, the cameras at ``z = 0``),
    so each ray meets a front face before any back face. It halves the triangles
    llvmpipe rasterises.
    """
    from OpenGL import GL

    (GL.glEnable if cull else GL.glDisable)(GL.GL_CULL_FACE)


@dataclass
class _GLScene:
    """GL resources of one uploaded scene (released by :meth:`_Passes.release`)."""

    meshes: list[Mesh]
    vao_color: int
    vao_gt: int
    buffers: list[int]
    textures: list[int]
    draws: list[tuple[int, int, int]]  # (texture, first index, index count) per mesh
    closed: int  # indices of the closed meshes, which come first (drawn with back-face culling)
    count: int  # indices of the whole scene
    meta: dict = field(default_factory=dict)


class _Passes:
    """The two passes of a view and the framebuffers they draw into.

    Colour: our flat shader (texture x per-vertex shade, trilinear mipmapped
    texture lookups) into a ``_MSAA_SAMPLES``-sample RGBA8 framebuffer, resolved
    by a same-size blit (the average of the samples) into a single-sample one.
    Ground truth: no multisampling, camera-space ``Z`` into ``GL_R32F`` with a
    linear ``GL_DEPTH_COMPONENT32F`` visibility test.
    """

    def __init__(self, width: int, height: int) -> None:
        from OpenGL import GL

        self.color_program = _program(_COLOR_VERT, _COLOR_FRAG)
        self.loc_color_pv = GL.glGetUniformLocation(self.color_program, "PV")
        GL.glUseProgram(self.color_program)
        GL.glUniform1i(GL.glGetUniformLocation(self.color_program, "tex"), 0)
        GL.glUseProgram(0)
        self.gt_program = _program(_GT_VERT, _GT_FRAG)
        self.loc_gt_pv = GL.glGetUniformLocation(self.gt_program, "PV")
        self.loc_far = GL.glGetUniformLocation(self.gt_program, "inv_far")
        # untextured meshes sample a white texture: colour = shade exactly (3 x 3: llvmpipe
        # compiles other shader variants for power-of-two textures; scenes avoid them too)
        self.white = self._texture(np.full((3, 3, 3), 255, dtype=np.uint8))
        self.fbs: list[tuple[int, list[int]]] = []
        self.resize(width, height)

    def resize(self, width: int, height: int) -> None:
        """(Re)allocate the framebuffers for ``width`` x ``height`` views."""
        from OpenGL import GL

        for fb in self.fbs:
            _delete_framebuffer(fb)
        self.w, self.h = width, height
        color, depth = GL.GL_COLOR_ATTACHMENT0, GL.GL_DEPTH_ATTACHMENT
        self.fb_msaa = _framebuffer([(color, GL.GL_RGBA8), (depth, GL.GL_DEPTH_COMPONENT24)],
                                    width, height, _MSAA_SAMPLES, "multisampled colour")
        self.fb_resolve = _framebuffer([(color, GL.GL_RGBA8)], width, height, 1, "colour")
        self.fb_gt = _framebuffer([(color, GL.GL_R32F), (depth, GL.GL_DEPTH_COMPONENT32F)],
                                  width, height, 1, "float32 depth")
        self.fbs = [self.fb_msaa, self.fb_resolve, self.fb_gt]

    def delete(self) -> None:
        from OpenGL import GL

        for fb in self.fbs:
            _delete_framebuffer(fb)
        self.fbs = []
        GL.glDeleteTextures(1, [self.white])
        GL.glDeleteProgram(self.color_program)
        GL.glDeleteProgram(self.gt_program)

    # ------------------------------------------------------------------ uploads
    @staticmethod
    def _texture(image: np.ndarray) -> int:
        """Upload an (h, w, 3 or 4) uint8 image, row 0 at texture coordinate t = 0, with mipmaps.

        Stored as RGBA8 whatever the source: llvmpipe uploads and mipmaps RGBA8 about 2.7x
        faster than RGB8 (and samples it ~5 % faster), with the same RGB values (the shader ignores alpha), and
        its RGB -> RGBA conversion on upload is 3x faster than numpy's or PIL's.
        """
        from OpenGL import GL

        tex = GL.glGenTextures(1)
        GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
        h, w = image.shape[:2]
        source = GL.GL_RGBA if image.shape[2] == 4 else GL.GL_RGB
        GL.glTexImage2D(GL.GL_TEXTURE_2D, 0, GL.GL_RGBA8, w, h, 0, source,
                        GL.GL_UNSIGNED_BYTE, image)
        GL.glGenerateMipmap(GL.GL_TEXTURE_2D)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR_MIPMAP_LINEAR)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_S, GL.GL_REPEAT)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_T, GL.GL_REPEAT)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
        return int(tex)

    def upload(self, meshes: Sequence[Mesh], meta: dict) -> _GLScene:
        """One vertex and one index buffer for the scene; one texture per distinct image.

        Closed meshes come first in the index buffer, open ones after: the depth
        pass draws each group in one call (llvmpipe's per-draw cost dominates
        small scenes), the colour pass one range per mesh, in the same order.
        """
        from OpenGL import GL

        meshes = sorted(meshes, key=lambda m: not m.closed)  # stable: scene order within groups
        closed = sum(int(m.faces.size) for m in meshes if m.closed)
        textures: dict[int, int] = {}
        draws = []
        first = 0
        for m in meshes:
            if m.image is None:
                tex = self.white
            else:
                key = id(m.image)
                if key not in textures:
                    textures[key] = self._texture(m.image)
                tex = textures[key]
            draws.append((tex, first, int(m.faces.size)))
            first += int(m.faces.size)
        vertices = np.concatenate([m.vertices for m in meshes])
        offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
        faces = np.concatenate([m.faces + np.uint32(o) for m, o in zip(meshes, offsets)])
        vao_color, vao_gt = (int(v) for v in GL.glGenVertexArrays(2))
        vbo, ebo = (int(b) for b in GL.glGenBuffers(2))
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, vbo)
        GL.glBufferData(GL.GL_ARRAY_BUFFER, vertices.nbytes, vertices, GL.GL_STATIC_DRAW)
        for vao, attributes in ((vao_color, ((0, 3, 0), (1, 2, 12), (2, 3, 20))),
                                (vao_gt, ((0, 3, 0),))):
            GL.glBindVertexArray(vao)
            GL.glBindBuffer(GL.GL_ARRAY_BUFFER, vbo)
            for loc, size, offset in attributes:
                GL.glEnableVertexAttribArray(loc)
                GL.glVertexAttribPointer(loc, size, GL.GL_FLOAT, GL.GL_FALSE, _STRIDE,
                                         ctypes.c_void_p(offset))
            GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, ebo)
            if vao == vao_color:
                GL.glBufferData(GL.GL_ELEMENT_ARRAY_BUFFER, faces.nbytes, faces,
                                GL.GL_STATIC_DRAW)
        GL.glBindVertexArray(0)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
        return _GLScene(meshes, vao_color, vao_gt, [vbo, ebo], list(textures.values()),
                        draws, closed, int(faces.size), meta)

    def release(self, up: _GLScene) -> None:
        from OpenGL import GL

        GL.glDeleteVertexArrays(2, [up.vao_color, up.vao_gt])
        GL.glDeleteBuffers(len(up.buffers), up.buffers)
        if up.textures:
            GL.glDeleteTextures(len(up.textures), up.textures)
        up.buffers, up.textures, up.draws = [], [], []

    # ------------------------------------------------------------------ passes
    @staticmethod
    def _common_state() -> None:
        from OpenGL import GL

        GL.glDisable(GL.GL_BLEND)
        GL.glCullFace(GL.GL_BACK)
        GL.glFrontFace(GL.GL_CCW)
        GL.glPolygonMode(GL.GL_FRONT_AND_BACK, GL.GL_FILL)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glDepthFunc(GL.GL_LESS)
        GL.glDepthRange(0.0, 1.0)

    def color(self, up: _GLScene, pv: np.ndarray, background: Sequence[float]) -> np.ndarray:
        """(H, W, 3) uint8 colour, row 0 at the top."""
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fb_msaa[0])
        GL.glViewport(0, 0, self.w, self.h)
        GL.glEnable(GL.GL_MULTISAMPLE)
        self._common_state()
        GL.glClearBufferfv(GL.GL_COLOR, 0, np.array([*background, 1.0], dtype=np.float32))
        GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
        GL.glUseProgram(self.color_program)
        GL.glUniformMatrix4fv(self.loc_color_pv, 1, GL.GL_TRUE, pv)
        GL.glActiveTexture(GL.GL_TEXTURE0)
        GL.glBindVertexArray(up.vao_color)
        for tex, first, count in up.draws:
            _set_culling(first < up.closed)
            GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
            GL.glDrawElements(GL.GL_TRIANGLES, count, GL.GL_UNSIGNED_INT,
                              ctypes.c_void_p(4 * first))
        GL.glBindVertexArray(0)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
        GL.glUseProgram(0)
        # same-size blit of a multisampled buffer = the average of each pixel's samples
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.fb_msaa[0])
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, self.fb_resolve[0])
        GL.glBlitFramebuffer(0, 0, self.w, self.h, 0, 0, self.w, self.h,
                             GL.GL_COLOR_BUFFER_BIT, GL.GL_NEAREST)
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.fb_resolve[0])
        out = np.empty((self.h, self.w, 3), dtype=np.uint8)
        GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0)
        GL.glReadPixels(0, 0, self.w, self.h, GL.GL_RGB, GL.GL_UNSIGNED_BYTE, out.ctypes.data)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        return out[::-1].copy()  # GL rows run bottom-up

    def depth(self, up: _GLScene, pv: np.ndarray, far: float) -> np.ndarray:
        """(H, W) float32 camera-space Z at pixel centres (``inf``: no surface), row 0 at top."""
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fb_gt[0])
        GL.glViewport(0, 0, self.w, self.h)
        GL.glDisable(GL.GL_MULTISAMPLE)
        self._common_state()
        GL.glClearBufferfv(GL.GL_COLOR, 0, np.array([np.inf, 0, 0, 0], dtype=np.float32))
        GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
        GL.glUseProgram(self.gt_program)
        GL.glUniformMatrix4fv(self.loc_gt_pv, 1, GL.GL_TRUE, pv)
        GL.glUniform1f(self.loc_far, 1.0 / far)
        GL.glBindVertexArray(up.vao_gt)
        for first, count, cull in ((0, up.closed, True), (up.closed, up.count - up.closed, False)):
            if count:
                _set_culling(cull)
                GL.glDrawElements(GL.GL_TRIANGLES, count, GL.GL_UNSIGNED_INT,
                                  ctypes.c_void_p(4 * first))
        GL.glBindVertexArray(0)
        GL.glUseProgram(0)
        out = np.empty((self.h, self.w), dtype=np.float32)
        GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0)
        GL.glReadPixels(0, 0, self.w, self.h, GL.GL_RED, GL.GL_FLOAT, out.ctypes.data)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        return out[::-1].copy()  # GL rows run bottom-up


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
    probe : bool
        Probe the backend in a subprocess first (default). ``False`` skips the
        probe for a named backend that :func:`resolve_backend` already found
        working on this machine (worker processes of a pool).
    threads : int, optional
        Rasterizer threads of Mesa's llvmpipe (``LP_NUM_THREADS``); ``None``
        leaves its default (one per core, or the environment's value). ``0``
        rasterizes in the calling thread: the least CPU per image (measured
        here: ~15 % less than with worker threads), the right choice when
        several processes already share the cores. Images do not depend on it.
        The driver reads it once per process, at the first renderer: a later
        renderer asking for another value raises ``ValueError``.

    Raises
    ------
    GLBackendError
        If no requested backend starts (the message names each backend tried,
        its error and the fix: a pip or a Debian package).

    Examples
    --------
    >>> import trimesh
    >>> from synth.rig import StereoRig
    >>> quad = trimesh.Trimesh([[-1, -1, 2], [1, -1, 2], [1, 1, 2], [-1, 1, 2]],
    ...                        [[0, 1, 2], [0, 2, 3]], process=False)
    >>> rig = StereoRig.default(32, 24)
    >>> with Renderer(32, 24) as r:
    ...     view = r.render_view([quad], rig, eye="left")
    >>> float(view.depth[12, 16])
    2.0
    """

    def __init__(self, width: int, height: int, *, backend: str = "auto",
                 probe: bool = True, threads: int | None = None) -> None:
        for name, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
                raise ValueError(f"{name} must be a positive int, got {value!r}")
        check_backend_name(backend)
        check_threads(threads)
        refuse_late_threads(threads)
        self.width, self.height = int(width), int(height)
        self._closed = True
        self._held: dict[int, tuple[Any, _GLScene]] = {}
        self.backend = choose_backend(backend, probe=probe)
        try:
            with driver_threads(threads):
                self._context = open_context(self.backend)
            from OpenGL import GL

            GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
            GL.glPixelStorei(GL.GL_UNPACK_ALIGNMENT, 1)
            self._passes = _Passes(self.width, self.height)
            self.gl_renderer = GL.glGetString(GL.GL_RENDERER).decode()
            self.gl_version = GL.glGetString(GL.GL_VERSION).decode()
        except GLBackendError as exc:
            raise GLBackendError(f"the {self.backend} backend failed to start: {exc.problem}",
                                 fix=exc.fix) from exc
        except Exception as exc:
            raise GLBackendError(
                f"the {self.backend} backend failed to start in this process: "
                f"{type(exc).__name__}: {exc}", fix=DEBIAN_FIX[self.backend]
            ) from exc
        self._closed = False

    # -------------------------------------------------------------- lifetime
    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Free every GL resource and the context (idempotent)."""
        if self._closed:
            return
        self._context.make_current()
        for _, up in list(self._held.values()):
            self._passes.release(up)
        self._held.clear()
        self._passes.delete()
        self._context.destroy()  # only ours: the EGL display, shared by all, stays initialised
        self._closed = True

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this Renderer is closed; open a new one (use it as a `with` block)")

    # -------------------------------------------------------------- uploads
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
        meshes, background, meta = as_meshes(scene)
        self._context.make_current()
        up = self._passes.upload(meshes, {**meta, "background": background})
        self._held[key] = (scene, up)  # keeps `scene` alive so its id is not reused
        try:
            yield {k: v for k, v in up.meta.items() if k != "background"}
        finally:
            del self._held[key]
            self._context.make_current()
            self._passes.release(up)

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
            check_depth_range(up.meshes, rig)
            return self._render(up, rig, eye)

    def _render(self, up: _GLScene, rig: StereoRig, eye: str) -> ViewRender:
        self._context.make_current()
        if (rig.width, rig.height) != (self.width, self.height):
            self.width, self.height = rig.width, rig.height
            self._passes.resize(rig.width, rig.height)
        pv = (_projection(rig) @ np.linalg.inv(_camera_pose(rig, eye))).astype(np.float32)
        color = self._passes.color(up, pv, up.meta["background"])
        depth = self._passes.depth(up, pv, rig.far)
        return ViewRender(color=color, depth=depth)
