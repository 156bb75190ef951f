"""The render passes: shader programs, framebuffers, uploaded scenes, colour and exact depth.

:class:`Passes` owns the GL objects of one context (made current by :class:`synth.render.Renderer`
before every call): the colour pass (4x MSAA, resolved to the pixel average) and the ground-truth
pass (no multisampling, float32 ``Z`` at each pixel centre into a ``GL_R32F`` target, linear
float32 depth for visibility). See ``docs/ground-truth.md`` for why each choice keeps the depth
exact. PyOpenGL is imported inside the functions: this module imports no GL at import time.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

from stereoforge.errors import ParameterError
from synth.render.backend import GLBackendError
from synth.render.meshes import Mesh
from synth.render.shading import HEADER, TEXTURE_LOD

__all__ = ["GLLimits", "GLScene", "Passes", "VERTEX_STRIDE", "compile_program",
           "delete_framebuffer", "draw_groups", "framebuffer"]


@dataclass(frozen=True)
class GLLimits:
    """The size limits of the current GL context, queried once per :class:`Passes`.

    Attributes
    ----------
    renderbuffer : int
        ``GL_MAX_RENDERBUFFER_SIZE``: the largest side of a framebuffer attachment.
    texture : int
        ``GL_MAX_TEXTURE_SIZE``: the largest side of a texture.
    viewport : (int, int)
        ``GL_MAX_VIEWPORT_DIMS``.
    """

    renderbuffer: int
    texture: int
    viewport: tuple[int, int]

    @classmethod
    def query(cls) -> GLLimits:
        """The limits of the context current in this thread."""
        from OpenGL import GL

        dims = np.asarray(GL.glGetIntegerv(GL.GL_MAX_VIEWPORT_DIMS)).ravel()
        return cls(int(np.asarray(GL.glGetIntegerv(GL.GL_MAX_RENDERBUFFER_SIZE)).ravel()[0]),
                   int(np.asarray(GL.glGetIntegerv(GL.GL_MAX_TEXTURE_SIZE)).ravel()[0]),
                   (int(dims[0]), int(dims[1])))

    def check_view(self, width: int, height: int) -> None:
        """Refuse a ``width`` x ``height`` view larger than the framebuffer and viewport limits."""
        for name, value, viewport in (("width", width, self.viewport[0]),
                                      ("height", height, self.viewport[1])):
            limit = min(self.renderbuffer, viewport)
            if value > limit:
                raise ParameterError(
                    f"{name}: expected at most {limit} pixels, the largest view this GL context "
                    f"renders (GL_MAX_RENDERBUFFER_SIZE = {self.renderbuffer}, "
                    f"GL_MAX_VIEWPORT_DIMS = {self.viewport[0]} x {self.viewport[1]}), got "
                    f"{value}; render a smaller image")

    def check_texture(self, width: int, height: int) -> None:
        """Refuse a texture with a side above ``GL_MAX_TEXTURE_SIZE``."""
        if max(width, height) > self.texture:
            raise ParameterError(
                f"texture: expected sides of at most GL_MAX_TEXTURE_SIZE = {self.texture} "
                f"pixels, got {width} x {height}; use a smaller texture")


#: Samples per pixel of the colour pass (its resolve averages them: area antialiasing).
_MSAA_SAMPLES = 4
# Interleaved vertex layout shared by both passes: position (3), texcoord (2), shade (3).
VERTEX_STRIDE = 8 * 4

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
# texture x per-vertex shade, the texture sampled at a mip level of our own (synth.render.shading)
_COLOR_FRAG = HEADER + """in vec2 uv;
in vec3 mult;
uniform sampler2D tex;
layout(location = 0) out vec4 out_color;
""" + TEXTURE_LOD + """
void main() {
    out_color = vec4(clamp(texture_lod(tex, uv).rgb * mult, 0.0, 1.0), 1.0);
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

def compile_program(vert: str, frag: str) -> int:
    from OpenGL import GL
    from OpenGL.GL import shaders

    return shaders.compileProgram(
        shaders.compileShader(vert, GL.GL_VERTEX_SHADER),
        shaders.compileShader(frag, GL.GL_FRAGMENT_SHADER),
        validate=False,
    )


def framebuffer(attachments: Sequence[tuple[int, int]], width: int, height: int,
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


def delete_framebuffer(fb: tuple[int, list[int]]) -> None:
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


def draw_groups(up: GLScene) -> None:
    """Draw the bound VAO's scene in two calls: closed meshes culled, open ones not; unbind."""
    from OpenGL import GL

    for first, count, cull in ((0, up.closed, True), (up.closed, up.count - up.closed, False)):
        if count:
            _set_culling(cull)
            GL.glDrawElements(GL.GL_TRIANGLES, count, GL.GL_UNSIGNED_INT,
                              ctypes.c_void_p(4 * first))
    GL.glBindVertexArray(0)
    GL.glUseProgram(0)


@dataclass
class GLScene:
    """GL resources of one uploaded scene (released by :meth:`Passes.release`)."""

    meshes: list[Mesh]
    vao_color: int
    vao_gt: int
    buffers: list[int]
    textures: list[int]
    draws: list[tuple[int, int, int]]  # (texture, first index, index count) per mesh
    closed: int  # indices of the closed meshes, which come first (drawn with back-face culling)
    count: int  # indices of the whole scene
    meta: dict = field(default_factory=dict)
    instances: list[int] = field(default_factory=list)  # instance id (scene order + 1) per mesh
    vao_label: int = 0  # made by the first labels pass (normals and ids in their own buffer)
    lit: Any = None  # synth.render.lighting.LitScene of a lit scene, else None (flat program)


class Passes:
    """The two passes of a view and the framebuffers they draw into.

    Colour: our flat shader (texture x per-vertex shade, trilinear mipmapped
    texture lookups at a mip level of our own, :mod:`synth.render.shading`) into a
    ``_MSAA_SAMPLES``-sample RGBA8 framebuffer, resolved
    by a same-size blit (the average of the samples) into a single-sample one.
    Ground truth: no multisampling, camera-space ``Z`` into ``GL_R32F`` with a
    linear ``GL_DEPTH_COMPONENT32F`` visibility test.
    """

    def __init__(self, width: int, height: int) -> None:
        from OpenGL import GL

        self.limits = GLLimits.query()
        self.limits.check_view(width, height)  # before any GL object exists
        self.color_program = compile_program(_COLOR_VERT, _COLOR_FRAG)
        self.loc_color_pv = GL.glGetUniformLocation(self.color_program, "PV")
        GL.glUseProgram(self.color_program)
        GL.glUniform1i(GL.glGetUniformLocation(self.color_program, "tex"), 0)
        GL.glUseProgram(0)
        self.gt_program = compile_program(_GT_VERT, _GT_FRAG)
        self.loc_gt_pv = GL.glGetUniformLocation(self.gt_program, "PV")
        self.loc_far = GL.glGetUniformLocation(self.gt_program, "inv_far")
        # untextured meshes sample a white texture: colour = shade exactly (3 x 3: llvmpipe
        # compiles other shader variants for power-of-two textures; scenes avoid them too)
        self.white = self._texture(np.full((3, 3, 3), 255, dtype=np.uint8))
        self.lit_program: Any = None  # compiled at the first lit scene (synth.render.lighting)
        self.fbs: list[tuple[int, list[int]]] = []
        self.resize(width, height)

    def resize(self, width: int, height: int) -> None:
        """(Re)allocate the framebuffers for ``width`` x ``height`` views."""
        from OpenGL import GL

        self.limits.check_view(width, height)
        for fb in self.fbs:
            delete_framebuffer(fb)
        self.w, self.h = width, height
        color, depth = GL.GL_COLOR_ATTACHMENT0, GL.GL_DEPTH_ATTACHMENT
        self.fb_msaa = framebuffer([(color, GL.GL_RGBA8), (depth, GL.GL_DEPTH_COMPONENT24)],
                                    width, height, _MSAA_SAMPLES, "multisampled colour")
        self.fb_resolve = framebuffer([(color, GL.GL_RGBA8)], width, height, 1, "colour")
        self.fb_gt = framebuffer([(color, GL.GL_R32F), (depth, GL.GL_DEPTH_COMPONENT32F)],
                                  width, height, 1, "float32 depth")
        self.fbs = [self.fb_msaa, self.fb_resolve, self.fb_gt]

    def delete(self) -> None:
        from OpenGL import GL

        for fb in self.fbs:
            delete_framebuffer(fb)
        self.fbs = []
        GL.glDeleteTextures(1, [self.white])
        if self.lit_program is not None:
            self.lit_program.delete()
        GL.glDeleteProgram(self.color_program)
        GL.glDeleteProgram(self.gt_program)

    # ------------------------------------------------------------------ uploads
    @staticmethod
    def _texture(image: np.ndarray) -> int:
        """Upload an (h, w, 3 or 4) uint8 image, row 0 at texture coordinate t = 0, with its
        mip levels made by :func:`synth.render.mipmaps.mip_chain` (not ``glGenerateMipmap``,
        whose filter is the driver's: the same levels on every GL implementation).

        Stored as RGBA8 whatever the source (an RGB image is made RGBX by ``mip_chain``):
        llvmpipe uploads RGBA8 about 2.7x faster than RGB8 and samples it ~5 % faster, with the
        same RGB values (the shader ignores alpha). Immutable storage (``glTexStorage2D``), one
        allocation for every level.
        """
        from OpenGL import GL

        from synth.render.mipmaps import mip_chain

        levels = mip_chain(image)  # RGBX
        tex = GL.glGenTextures(1)
        GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
        GL.glTexStorage2D(GL.GL_TEXTURE_2D, len(levels), GL.GL_RGBA8, image.shape[1],
                          image.shape[0])
        for level, pixels in enumerate(levels):
            h, w = pixels.shape[:2]
            GL.glTexSubImage2D(GL.GL_TEXTURE_2D, level, 0, 0, w, h, GL.GL_RGBA,
                               GL.GL_UNSIGNED_BYTE, pixels)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR_MIPMAP_LINEAR)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_S, GL.GL_REPEAT)
        GL.glTexParameteri(GL.GL_TEXTURE_2D, GL.GL_TEXTURE_WRAP_T, GL.GL_REPEAT)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
        return int(tex)

    def upload(self, meshes: Sequence[Mesh], meta: dict, *,
               lighting: tuple[float, list] | None = None) -> GLScene:
        """One vertex and one index buffer for the scene; one texture per distinct image.

        ``lighting`` (ambient, lights of :func:`synth.render.lighting.scene_lights`) makes the
        scene lit: a second vertex buffer and its shadow maps (:mod:`synth.render.lighting`).

        Closed meshes come first in the index buffer, open ones after: the depth
        pass draws each group in one call (llvmpipe's per-draw cost dominates
        small scenes), the colour pass one range per mesh, in the same order.
        """
        from OpenGL import GL

        order = sorted(range(len(meshes)), key=lambda i: not meshes[i].closed)  # stable
        meshes = [meshes[i] for i in order]  # closed first, scene order within groups
        closed = sum(int(m.faces.size) for m in meshes if m.closed)
        for m in meshes:  # every texture checked before anything is uploaded
            if m.image is not None:
                self.limits.check_texture(m.image.shape[1], m.image.shape[0])
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
                GL.glVertexAttribPointer(loc, size, GL.GL_FLOAT, GL.GL_FALSE, VERTEX_STRIDE,
                                         ctypes.c_void_p(offset))
            GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, ebo)
            if vao == vao_color:
                GL.glBufferData(GL.GL_ELEMENT_ARRAY_BUFFER, faces.nbytes, faces,
                                GL.GL_STATIC_DRAW)
        GL.glBindVertexArray(0)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
        up = GLScene(meshes, vao_color, vao_gt, [vbo, ebo], list(textures.values()),
                     draws, closed, int(faces.size), meta, [i + 1 for i in order])
        if lighting is not None:
            from synth.render import lighting as lit

            if self.lit_program is None:
                self.lit_program = lit.LitProgram(compile_program)
            up.lit = lit.upload_lit(self.lit_program, meshes, vbo, ebo, vao_gt, up.count,
                                    *lighting)
        return up

    def release(self, up: GLScene) -> None:
        from OpenGL import GL

        if up.lit is not None:
            from synth.render.lighting import release_lit

            release_lit(up.lit)
            up.lit = None
        GL.glDeleteVertexArrays(2, [up.vao_color, up.vao_gt])
        if up.vao_label:
            GL.glDeleteVertexArrays(1, [up.vao_label])
        GL.glDeleteBuffers(len(up.buffers), up.buffers)
        if up.textures:
            GL.glDeleteTextures(len(up.textures), up.textures)
        up.buffers, up.textures, up.draws = [], [], []

    # ------------------------------------------------------------------ passes
    @staticmethod
    def common_state() -> None:
        """The fixed-function state every pass sets, leaving none of it to the driver's defaults.

        Dithering is off: GL enables it by default and lets an implementation dither a colour
        written into a buffer of fewer bits (our RGBA8 colour target) as it likes (llvmpipe does
        not dither, so its images are unchanged; another driver might). ``GL_FRAMEBUFFER_SRGB``
        is off (its default): colours are written as the shader computes them, never encoded.
        """
        from OpenGL import GL

        GL.glDisable(GL.GL_DITHER)
        GL.glDisable(GL.GL_FRAMEBUFFER_SRGB)
        GL.glDisable(GL.GL_BLEND)
        GL.glCullFace(GL.GL_BACK)
        GL.glFrontFace(GL.GL_CCW)
        GL.glPolygonMode(GL.GL_FRONT_AND_BACK, GL.GL_FILL)
        GL.glEnable(GL.GL_DEPTH_TEST)
        GL.glDepthMask(GL.GL_TRUE)
        GL.glDepthFunc(GL.GL_LESS)
        GL.glDepthRange(0.0, 1.0)

    def _draw_meshes(self, up: GLScene, pv: np.ndarray, eye: Sequence[float], mode: int) -> None:
        """Each mesh's range with its texture: the flat program, or the lit one for a lit scene."""
        from OpenGL import GL

        lit = up.lit
        if lit is None:
            GL.glUseProgram(self.color_program)
            GL.glUniformMatrix4fv(self.loc_color_pv, 1, GL.GL_TRUE, pv)
            GL.glBindVertexArray(up.vao_color)
        else:
            self.lit_program.begin(lit, pv, eye, mode)
        GL.glActiveTexture(GL.GL_TEXTURE0)
        for i, (tex, first, count) in enumerate(up.draws):
            _set_culling(first < up.closed)
            if lit is not None:
                self.lit_program.set_material(lit, i, first < up.closed)
            GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
            GL.glDrawElements(GL.GL_TRIANGLES, count, GL.GL_UNSIGNED_INT,
                              ctypes.c_void_p(4 * first))
        GL.glBindVertexArray(0)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
        GL.glUseProgram(0)

    def color(self, up: GLScene, pv: np.ndarray, background: Sequence[float], *,
              eye: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
        """(H, W, 3) uint8 colour, row 0 at the top (``eye``: world position, lit scenes)."""
        out = self.color_rgba(up, pv, (*background, 1.0), eye=eye)
        return cv2.cvtColor(out, cv2.COLOR_RGBA2RGB)

    def color_rgba(self, up: GLScene, pv: np.ndarray, clear: Sequence[float], *,
                   eye: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
        """(H, W, 4) uint8 colour and coverage over the RGBA ``clear`` value, row 0 at the top
        (``clear`` = (0, 0, 0, 0): premultiplied by coverage, for :func:`~synth.render.sky.
        over_sky`)."""
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fb_msaa[0])
        GL.glViewport(0, 0, self.w, self.h)
        GL.glEnable(GL.GL_MULTISAMPLE)
        self.common_state()
        GL.glClearBufferfv(GL.GL_COLOR, 0, np.array(clear, dtype=np.float32))
        GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
        self._draw_meshes(up, pv, eye, 0)
        # same-size blit of a multisampled buffer = the average of each pixel's samples
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.fb_msaa[0])
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, self.fb_resolve[0])
        GL.glBlitFramebuffer(0, 0, self.w, self.h, 0, 0, self.w, self.h,
                             GL.GL_COLOR_BUFFER_BIT, GL.GL_NEAREST)
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.fb_resolve[0])
        # read as stored (RGBA: llvmpipe's RGB read-back converts pixel by pixel, ~4x slower)
        out = np.empty((self.h, self.w, 4), dtype=np.uint8)
        GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0)
        GL.glReadPixels(0, 0, self.w, self.h, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, out.ctypes.data)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        return out[::-1].copy()  # GL rows run bottom-up

    def highlight(self, up: GLScene, pv: np.ndarray, eye: Sequence[float]) -> np.ndarray:
        """(H, W) float32 rise of the displayed value (grey levels, the largest channel) that the
        specular term causes at each pixel centre of a lit scene; 0 where none. Row 0 at top."""
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fb_gt[0])
        GL.glViewport(0, 0, self.w, self.h)
        GL.glDisable(GL.GL_MULTISAMPLE)
        self.common_state()
        GL.glClearBufferfv(GL.GL_COLOR, 0, np.array([0, 0, 0, 0], dtype=np.float32))
        GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
        self._draw_meshes(up, pv, eye, 1)
        return self._read_float()

    def _read_float(self) -> np.ndarray:
        from OpenGL import GL

        out = np.empty((self.h, self.w), dtype=np.float32)
        GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0)
        GL.glReadPixels(0, 0, self.w, self.h, GL.GL_RED, GL.GL_FLOAT, out.ctypes.data)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        return out[::-1].copy()  # GL rows run bottom-up

    def depth(self, up: GLScene, pv: np.ndarray, far: float) -> np.ndarray:
        """(H, W) float32 camera-space Z at pixel centres (``inf``: no surface), row 0 at top."""
        from OpenGL import GL

        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fb_gt[0])
        GL.glViewport(0, 0, self.w, self.h)
        GL.glDisable(GL.GL_MULTISAMPLE)
        self.common_state()
        GL.glClearBufferfv(GL.GL_COLOR, 0, np.array([np.inf, 0, 0, 0], dtype=np.float32))
        GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
        GL.glUseProgram(self.gt_program)
        GL.glUniformMatrix4fv(self.loc_gt_pv, 1, GL.GL_TRUE, pv)
        GL.glUniform1f(self.loc_far, 1.0 / far)
        GL.glBindVertexArray(up.vao_gt)
        draw_groups(up)
        return self._read_float()
