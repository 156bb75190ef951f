"""The labels pass (optional ground truth): surface normals and instance ids per pixel.

A ground-truth pass like the depth pass of :mod:`synth.render.passes` (no multisampling, the
same linear float32 depth test, so it sees the surfaces the depth pass sees) into an
``RGBA32F`` target: the interpolated vertex normal turned toward the camera, and the instance
id. Made by :class:`~synth.render.Renderer` at its first labels render (the default passes
never compile it); it uses the scene's uploaded positions and indices plus a buffer of its own
for normals and ids, so the colour and depth passes' vertex layout is untouched. PyOpenGL is
imported inside the functions.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence

import numpy as np

from synth.render.passes import (
    VERTEX_STRIDE,
    GLScene,
    compile_program,
    delete_framebuffer,
    draw_groups,
    framebuffer,
)

__all__ = ["LabelPass"]

# The interpolated vertex normal turned toward the camera, and the instance id, of the surface
# the depth pass sees (the same linear depth test).
_LABEL_VERT = """#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec4 label;  // vertex normal (x, y, z), instance id
uniform mat4 PV;
out float z_cam;
out vec3 to_surface;
out vec3 normal;
flat out float instance;
uniform vec3 eye;
void main() {
    gl_Position = PV * vec4(position, 1.0);
    z_cam = position.z;
    to_surface = position - eye;
    normal = label.xyz;
    instance = label.w;
}
"""
_LABEL_FRAG = """#version 330 core
in float z_cam;
in vec3 to_surface;
in vec3 normal;
flat in float instance;
uniform float inv_far;
layout(location = 0) out vec4 out_label;
void main() {
    vec3 n = normalize(normal);
    if (dot(n, to_surface) > 0.0) n = -n;  // the side the camera sees
    out_label = vec4(n, instance);
    gl_FragDepth = z_cam * inv_far;
}
"""


class LabelPass:
    """The labels program and its ``RGBA32F`` framebuffer (with a float32 depth buffer)."""

    def __init__(self, width: int, height: int) -> None:
        self.program = compile_program(_LABEL_VERT, _LABEL_FRAG)
        self.fb: tuple[int, list[int]] | None = None
        self.resize(width, height)

    def resize(self, width: int, height: int) -> None:
        """(Re)allocate the framebuffer for ``width`` x ``height`` views."""
        from OpenGL import GL

        if self.fb is not None:
            delete_framebuffer(self.fb)
        self.w, self.h = width, height
        self.fb = framebuffer([(GL.GL_COLOR_ATTACHMENT0, GL.GL_RGBA32F),
                                (GL.GL_DEPTH_ATTACHMENT, GL.GL_DEPTH_COMPONENT32F)],
                               width, height, 1, "float32 labels")

    def delete(self) -> None:
        from OpenGL import GL

        if self.fb is not None:
            delete_framebuffer(self.fb)
            self.fb = None
        GL.glDeleteProgram(self.program)

    @staticmethod
    def _vao(up: GLScene) -> int:
        """Per-vertex normal and instance id in a buffer of their own (the colour and depth
        passes' vertex layout is untouched), bound with the scene's positions and indices."""
        from OpenGL import GL

        labels = np.concatenate([np.column_stack([m.normals, np.full(len(m.normals), k, np.float32)])
                                 for m, k in zip(up.meshes, up.instances)]).astype(np.float32)
        vao = int(GL.glGenVertexArrays(1))
        lbo = int(GL.glGenBuffers(1))
        GL.glBindVertexArray(vao)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, up.buffers[0])
        GL.glEnableVertexAttribArray(0)
        GL.glVertexAttribPointer(0, 3, GL.GL_FLOAT, GL.GL_FALSE, VERTEX_STRIDE,
                                 ctypes.c_void_p(0))
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, lbo)
        GL.glBufferData(GL.GL_ARRAY_BUFFER, labels.nbytes, labels, GL.GL_STATIC_DRAW)
        GL.glEnableVertexAttribArray(1)
        GL.glVertexAttribPointer(1, 4, GL.GL_FLOAT, GL.GL_FALSE, 16, ctypes.c_void_p(0))
        GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, up.buffers[1])
        GL.glBindVertexArray(0)
        GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
        up.buffers.append(lbo)
        up.vao_label = vao
        return vao

    def render(self, up: GLScene, pv: np.ndarray, far: float,
               eye: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """(H, W, 3) float32 unit normals facing the camera at ``eye`` (0 where no surface) and
        (H, W) uint32 instance ids (0: background) of the surfaces the depth pass sees. The
        caller (:meth:`synth.render.Renderer.render_labels`) has set the common GL state
        (:meth:`~synth.render.passes.Passes.common_state`)."""
        from OpenGL import GL

        vao = up.vao_label or self._vao(up)
        prog = self.program
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fb[0])
        GL.glViewport(0, 0, self.w, self.h)
        GL.glDisable(GL.GL_MULTISAMPLE)
        GL.glClearBufferfv(GL.GL_COLOR, 0, np.zeros(4, dtype=np.float32))
        GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
        GL.glUseProgram(prog)
        GL.glUniformMatrix4fv(GL.glGetUniformLocation(prog, "PV"), 1, GL.GL_TRUE, pv)
        GL.glUniform1f(GL.glGetUniformLocation(prog, "inv_far"), 1.0 / far)
        GL.glUniform3f(GL.glGetUniformLocation(prog, "eye"), *(float(e) for e in eye))
        GL.glBindVertexArray(vao)
        draw_groups(up)
        out = np.empty((self.h, self.w, 4), dtype=np.float32)
        GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0)
        GL.glReadPixels(0, 0, self.w, self.h, GL.GL_RGBA, GL.GL_FLOAT, out.ctypes.data)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        out = out[::-1]  # GL rows run bottom-up
        return np.ascontiguousarray(out[..., :3]), out[..., 3].astype(np.uint32)
