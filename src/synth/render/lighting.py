"""Lit scenes: per-fragment Blinn-Phong or GGX shading from several lights, shadow maps, highlight masks.

Only scenes that need it take this path (``SceneSpec.is_lit()``: a specular material or a lamp,
see :mod:`scenes.materials`); every other scene keeps the flat program of
:mod:`synth.render.passes` and its bytes. The lit program reads the scene's interleaved vertex
buffer (position, texcoord) plus a second buffer of its own (normal, tint), so the default
layout is untouched. Shadow maps are view-independent: they are drawn once per upload, one layer
of a ``GL_DEPTH_COMPONENT32F`` texture array per shadowed lamp, and sampled with hardware
depth comparison (2 x 2 percentage-closer filtering). PyOpenGL is imported inside the functions.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from stereoforge.errors import ParameterError
from synth.render.meshes import DISPLAY_GAMMA, Mesh
from synth.render.shading import HEADER, TEXTURE_LOD

__all__ = ["HIGHLIGHT_LEVELS", "SHADOW_MAP_SIZE", "Light", "LitScene", "LitProgram",
           "scene_lights", "upload_lit", "release_lit"]

#: A pixel is in a view's highlight mask where the specular term raises the displayed value of
#: some channel at the pixel centre by at least this many grey levels (of 255).
HIGHLIGHT_LEVELS = 8.0
#: Side of each shadow map, texels (the scene's bounding sphere fills it).
SHADOW_MAP_SIZE = 512
_MAX_LIGHTS = 8  # the classic light + scenes.materials.MAX_LAMPS
_MAX_LAYERS = 6 * (_MAX_LIGHTS - 1)  # every lamp a point lamp: six cube faces each


@dataclass(frozen=True)
class Light:
    """One light as the lit program sees it (world frame).

    ``vector`` is the direction the light travels for a directional light (``point`` False) or
    its position for a point light; ``shadows`` asks for a shadow map.
    """

    vector: tuple[float, float, float]
    point: bool
    intensity: float
    shadows: bool


def scene_lights(scene: Any) -> tuple[float, list[Light]]:
    """Ambient and lights of a lit SceneSpec: its classic light (unshadowed), then its lamps."""
    lt = scene.light
    lights = [Light(tuple(float(c) for c in lt.unit_direction()), False, float(lt.intensity),
                    False)]
    for lamp in scene.lamps:
        point = lamp.kind == "point"
        vec = lamp.position if point else tuple(np.asarray(lamp.direction) /
                                                np.linalg.norm(lamp.direction))
        lights.append(Light(tuple(float(c) for c in vec), point, float(lamp.intensity),
                            bool(lamp.shadows)))
    return float(lt.ambient), lights


# ----------------------------------------------------------------------------- light matrices
def _look_at(eye: np.ndarray, forward: np.ndarray) -> np.ndarray:
    f = forward / np.linalg.norm(forward)
    up = np.array([0.0, 1.0, 0.0]) if abs(f[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = s, u, -f
    m[:3, 3] = -m[:3, :3] @ eye
    return m


def _layers(light: Light, centre: np.ndarray, radius: float
            ) -> tuple[list[np.ndarray], list[np.ndarray], float]:
    """Shadow-map layers of a light: clip matrices, linear-depth rows, normalised depth bias.

    A directional light has one orthographic layer holding the scene's bounding sphere; a point
    light six 90-degree faces of a cube around it (+x, -x, +y, -y, +z, -z), chosen in the
    shader by the major axis of the light-to-fragment vector. Each layer stores the linear depth
    ``row . (X, 1)`` in [0, 1] along its axis; the bias is one texel at the far end.
    """
    size = float(SHADOW_MAP_SIZE)
    if light.point:
        eye = np.asarray(light.vector, dtype=np.float64)
        near = 0.01
        far = max(float(np.linalg.norm(eye - centre)) + radius, 2 * near)
        axes = [s * np.eye(3)[a] for a in range(3) for s in (1.0, -1.0)]
        half, texel = 1.0, 2.0 * far / size
    else:
        d = np.asarray(light.vector, dtype=np.float64)
        eye = centre - 2.0 * radius * d
        near, far = radius, 3.0 * radius
        axes = [d]
        half, texel = radius, 2.0 * radius / size
    mats, rows = [], []
    for f in axes:
        p = np.zeros((4, 4))
        if light.point:
            p[0, 0] = p[1, 1] = 1.0 / half  # 90 degrees
            p[2, 2] = -(far + near) / (far - near)
            p[2, 3] = -2.0 * far * near / (far - near)
            p[3, 2] = -1.0
        else:
            p[0, 0] = p[1, 1] = 1.0 / half
            p[2, 2] = -2.0 / (far - near)
            p[2, 3] = -(far + near) / (far - near)
            p[3, 3] = 1.0
        mats.append(p @ _look_at(eye, f))
        rows.append(np.array([*(f / (far - near)), (-(f @ eye) - near) / (far - near)]))
    return mats, rows, texel / (far - near)


# ----------------------------------------------------------------------------- shaders
_LIT_VERT = """#version 330 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec2 texcoord;
layout(location = 3) in vec3 normal;
layout(location = 4) in vec3 tint;
uniform mat4 PV;
out vec2 uv;
out vec3 p;
out vec3 nrm;
out vec3 albedo_tint;
void main() {
    gl_Position = PV * vec4(position, 1.0);
    uv = texcoord;
    p = position;
    nrm = normal;
    albedo_tint = tint;
}
"""
_LIT_FRAG = (HEADER + """in vec2 uv;
in vec3 p;
in vec3 nrm;
in vec3 albedo_tint;
uniform sampler2D tex;
uniform sampler2DArrayShadow shadow_maps;
uniform int n_lights;
uniform vec4 light_vec[%(n)d];      // w = 0: direction travelled; w = 1: position
uniform float light_intensity[%(n)d];
uniform int light_layer[%(n)d];     // first shadow map layer, < 0: no shadow
uniform float light_bias[%(n)d];    // depth bias of a texel, normalised
uniform mat4 layer_pv[%(m)d];
uniform vec4 layer_row[%(m)d];      // linear depth in [0, 1] = dot(row, vec4(X, 1))
uniform float ambient;
uniform vec3 eye;
uniform float specular;
uniform float shininess;
uniform float roughness;            // > 0: the GGX lobe of alpha = roughness^2; 0: Blinn-Phong
uniform int double_sided;
uniform int mode;                   // 0: colour; 1: highlight excess, grey levels
uniform float gamma;
layout(location = 0) out vec4 out_color;
""" + TEXTURE_LOD + """
void main() {
    vec3 n = normalize(nrm);
    if (double_sided == 1 && dot(n, -p) < 0.0) n = -n;  // the side the left camera sees
    vec3 v = normalize(eye - p);
    float diffuse = ambient;
    float spec = 0.0;
    for (int i = 0; i < n_lights; ++i) {
        vec3 l;
        float e = light_intensity[i];
        if (light_vec[i].w == 0.0) {
            l = -light_vec[i].xyz;
        } else {
            vec3 d = light_vec[i].xyz - p;
            float r2 = dot(d, d);
            l = d * inversesqrt(r2);
            e /= r2;
        }
        float ndl = dot(n, l);
        if (ndl <= 0.0) continue;
        if (light_layer[i] >= 0) {
            int layer = light_layer[i];
            if (light_vec[i].w != 0.0) {  // cube face of the major axis of light -> fragment
                vec3 d = abs(p - light_vec[i].xyz);
                vec3 sgn = p - light_vec[i].xyz;
                int axis = d.x >= d.y && d.x >= d.z ? 0 : (d.y >= d.z ? 1 : 2);
                layer += 2 * axis + (sgn[axis] < 0.0 ? 1 : 0);
            }
            vec4 q = layer_pv[layer] * vec4(p, 1.0);
            vec2 s = q.xy / q.w * 0.5 + 0.5;
            float slope = min(sqrt(max(1.0 - ndl * ndl, 0.0)) / ndl, 8.0);
            float ref = dot(layer_row[layer], vec4(p, 1.0)) - light_bias[i] * (1.0 + slope);
            e *= texture(shadow_maps, vec4(s, float(layer), ref));
        }
        diffuse += e * ndl;
        float ndh = max(dot(n, normalize(l + v)), 0.0);
        if (roughness > 0.0) {
            float a2 = roughness * roughness * roughness * roughness;
            float ndv = max(dot(n, v), 1e-4);
            float t = ndh * ndh * (a2 - 1.0) + 1.0;
            float g_l = 2.0 * ndl / (ndl + sqrt(a2 + (1.0 - a2) * ndl * ndl));
            float g_v = 2.0 * ndv / (ndv + sqrt(a2 + (1.0 - a2) * ndv * ndv));
            spec += e * a2 / (3.14159265358979 * t * t) * g_l * g_v / (4.0 * ndv);
        } else {
            spec += e * pow(ndh, shininess);
        }
    }
    vec3 matte = pow(texture_lod(tex, uv).rgb * albedo_tint, vec3(gamma)) * diffuse;
    vec3 lit = matte + vec3(specular * spec);
    vec3 c = pow(clamp(lit, 0.0, 1.0), vec3(1.0 / gamma));
    if (mode == 0) {
        out_color = vec4(c, 1.0);
    } else {
        vec3 rise = (c - pow(clamp(matte, 0.0, 1.0), vec3(1.0 / gamma))) * 255.0;
        out_color = vec4(max(rise.r, max(rise.g, rise.b)), 0.0, 0.0, 1.0);
    }
}
""") % {"n": _MAX_LIGHTS, "m": _MAX_LAYERS}
_SHADOW_VERT = """#version 330 core
layout(location = 0) in vec3 position;
uniform mat4 PV;
uniform vec4 row;
out float depth;
void main() {
    gl_Position = PV * vec4(position, 1.0);
    depth = dot(row, vec4(position, 1.0));
}
"""
_SHADOW_FRAG = """#version 330 core
in float depth;
void main() { gl_FragDepth = depth; }
"""


@dataclass
class LitScene:
    """GL resources and light uniforms of one uploaded lit scene (see :func:`release_lit`)."""

    vao: int
    vbo: int
    shadow_texture: int
    ambient: float
    vectors: np.ndarray  # (L, 4) float32
    intensities: np.ndarray  # (L,) float32
    layers: np.ndarray  # (L,) int32 first shadow layer, -1 = unshadowed
    biases: np.ndarray  # (L,) float32
    matrices: np.ndarray  # (K, 4, 4) float32 per shadow layer, row-major
    rows: np.ndarray  # (K, 4) float32 per shadow layer
    materials: list[tuple[float, float, float]]  # (specular, shininess, roughness) per draw


class LitProgram:
    """The lit shader and the shadow-map shader of one context (compiled on first lit scene)."""

    def __init__(self, program: Any) -> None:
        from OpenGL import GL

        self.program = program(_LIT_VERT, _LIT_FRAG)
        self.shadow_program = program(_SHADOW_VERT, _SHADOW_FRAG)
        self.loc = {name: GL.glGetUniformLocation(self.program, name) for name in (
            "PV", "n_lights", "light_vec", "light_intensity", "light_layer", "light_bias",
            "layer_pv", "layer_row", "ambient", "eye", "specular", "shininess", "roughness",
            "double_sided",
            "mode", "gamma")}
        self.loc_shadow_pv = GL.glGetUniformLocation(self.shadow_program, "PV")
        self.loc_shadow_row = GL.glGetUniformLocation(self.shadow_program, "row")
        GL.glUseProgram(self.program)
        GL.glUniform1i(GL.glGetUniformLocation(self.program, "tex"), 0)
        GL.glUniform1i(GL.glGetUniformLocation(self.program, "shadow_maps"), 1)
        GL.glUseProgram(0)
        self.fbo = int(GL.glGenFramebuffers(1))

    def delete(self) -> None:
        from OpenGL import GL

        GL.glDeleteFramebuffers(1, [self.fbo])
        GL.glDeleteProgram(self.program)
        GL.glDeleteProgram(self.shadow_program)

    def begin(self, lit: LitScene, pv: np.ndarray, eye: Sequence[float], mode: int) -> None:
        """Bind the program, the scene's VAO and shadow maps and set the per-view uniforms."""
        from OpenGL import GL

        loc = self.loc
        GL.glUseProgram(self.program)
        GL.glUniformMatrix4fv(loc["PV"], 1, GL.GL_TRUE, pv)
        n = len(lit.intensities)
        GL.glUniform1i(loc["n_lights"], n)
        GL.glUniform4fv(loc["light_vec"], n, lit.vectors)
        GL.glUniform1fv(loc["light_intensity"], n, lit.intensities)
        GL.glUniform1iv(loc["light_layer"], n, lit.layers)
        GL.glUniform1fv(loc["light_bias"], n, lit.biases)
        if len(lit.rows):
            GL.glUniformMatrix4fv(loc["layer_pv"], len(lit.rows), GL.GL_TRUE, lit.matrices)
            GL.glUniform4fv(loc["layer_row"], len(lit.rows), lit.rows)
        GL.glUniform1f(loc["ambient"], lit.ambient)
        GL.glUniform3f(loc["eye"], *(float(c) for c in eye))
        GL.glUniform1i(loc["mode"], mode)
        GL.glUniform1f(loc["gamma"], DISPLAY_GAMMA)
        GL.glActiveTexture(GL.GL_TEXTURE1)
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, lit.shadow_texture)
        GL.glActiveTexture(GL.GL_TEXTURE0)
        GL.glBindVertexArray(lit.vao)

    def set_material(self, lit: LitScene, draw: int, closed: bool) -> None:
        from OpenGL import GL

        specular, shininess, roughness = lit.materials[draw]
        GL.glUniform1f(self.loc["specular"], specular)
        GL.glUniform1f(self.loc["shininess"], shininess)
        GL.glUniform1f(self.loc["roughness"], roughness)
        GL.glUniform1i(self.loc["double_sided"], 0 if closed else 1)

    def shadow_maps(self, meshes: Sequence[Mesh], vao_gt: int, count: int,
                    lights: Sequence[Light]) -> tuple[int, dict[str, np.ndarray]]:
        """Draw the shadow layers of every shadowed light; the texture and the light uniforms."""
        from OpenGL import GL

        vertices = np.concatenate([m.vertices[:, :3] for m in meshes]).astype(np.float64)
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        centre = (lo + hi) / 2.0
        radius = max(float(np.linalg.norm(vertices - centre, axis=1).max()), 1e-6) * 1.001
        layers = np.full(len(lights), -1, dtype=np.int32)
        biases = np.zeros(len(lights), dtype=np.float32)
        mats: list[np.ndarray] = []
        rows: list[np.ndarray] = []
        for i, light in enumerate(lights):
            if light.shadows:
                m, r, biases[i] = _layers(light, centre, radius)
                layers[i] = len(mats)
                mats += m
                rows += r
        tex = int(GL.glGenTextures(1))
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, tex)
        size = SHADOW_MAP_SIZE
        GL.glTexImage3D(GL.GL_TEXTURE_2D_ARRAY, 0, GL.GL_DEPTH_COMPONENT32F, size, size,
                        max(len(mats), 1), 0, GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT, None)
        for pname, value in ((GL.GL_TEXTURE_MIN_FILTER, GL.GL_LINEAR),
                             (GL.GL_TEXTURE_MAG_FILTER, GL.GL_LINEAR),
                             (GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_EDGE),
                             (GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_EDGE),
                             (GL.GL_TEXTURE_COMPARE_MODE, GL.GL_COMPARE_REF_TO_TEXTURE),
                             (GL.GL_TEXTURE_COMPARE_FUNC, GL.GL_LEQUAL)):
            GL.glTexParameteri(GL.GL_TEXTURE_2D_ARRAY, pname, value)
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, 0)
        if mats:
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fbo)
            GL.glDrawBuffer(GL.GL_NONE)
            GL.glReadBuffer(GL.GL_NONE)
            GL.glViewport(0, 0, size, size)
            GL.glDisable(GL.GL_MULTISAMPLE)
            GL.glDisable(GL.GL_CULL_FACE)  # every face casts: open surfaces have two sides
            GL.glEnable(GL.GL_DEPTH_TEST)
            GL.glDepthMask(GL.GL_TRUE)
            GL.glDepthFunc(GL.GL_LESS)
            GL.glUseProgram(self.shadow_program)
            GL.glBindVertexArray(vao_gt)
            for k, (mat, row) in enumerate(zip(mats, rows)):
                GL.glFramebufferTextureLayer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT, tex, 0, k)
                GL.glClearBufferfv(GL.GL_DEPTH, 0, np.array([1.0], dtype=np.float32))
                GL.glUniformMatrix4fv(self.loc_shadow_pv, 1, GL.GL_TRUE,
                                      mat.astype(np.float32))
                GL.glUniform4f(self.loc_shadow_row, *(float(c) for c in row))
                GL.glDrawElements(GL.GL_TRIANGLES, count, GL.GL_UNSIGNED_INT, ctypes.c_void_p(0))
            GL.glBindVertexArray(0)
            GL.glUseProgram(0)
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        uniforms = {"layers": layers, "biases": biases,
                    "matrices": np.ascontiguousarray(mats, dtype=np.float32).reshape(-1, 4, 4),
                    "rows": np.ascontiguousarray(rows, dtype=np.float32).reshape(-1, 4)}
        return tex, uniforms


def upload_lit(program: LitProgram, meshes: Sequence[Mesh], vbo: int, ebo: int, vao_gt: int,
               count: int, ambient: float, lights: Sequence[Light]) -> LitScene:
    """The second vertex buffer (normal, tint), the lit VAO and the shadow maps of a scene.

    ``meshes`` in the order of the scene's vertex buffer ``vbo`` and index buffer ``ebo``.
    """
    from OpenGL import GL

    if len(lights) > _MAX_LIGHTS:
        raise ParameterError(f"lights: expected at most {_MAX_LIGHTS}, got {len(lights)}; "
                             "drop some lamps")
    extra = np.concatenate([np.concatenate([m.normals, m.tint], axis=1) for m in meshes])
    extra = np.ascontiguousarray(extra, dtype=np.float32)
    vao, own = int(GL.glGenVertexArrays(1)), int(GL.glGenBuffers(1))
    GL.glBindVertexArray(vao)
    GL.glBindBuffer(GL.GL_ARRAY_BUFFER, vbo)
    for loc, size, offset in ((0, 3, 0), (1, 2, 12)):
        GL.glEnableVertexAttribArray(loc)
        GL.glVertexAttribPointer(loc, size, GL.GL_FLOAT, GL.GL_FALSE, 32, ctypes.c_void_p(offset))
    GL.glBindBuffer(GL.GL_ARRAY_BUFFER, own)
    GL.glBufferData(GL.GL_ARRAY_BUFFER, extra.nbytes, extra, GL.GL_STATIC_DRAW)
    for loc, offset in ((3, 0), (4, 12)):
        GL.glEnableVertexAttribArray(loc)
        GL.glVertexAttribPointer(loc, 3, GL.GL_FLOAT, GL.GL_FALSE, 24, ctypes.c_void_p(offset))
    GL.glBindBuffer(GL.GL_ELEMENT_ARRAY_BUFFER, ebo)
    GL.glBindVertexArray(0)
    GL.glBindBuffer(GL.GL_ARRAY_BUFFER, 0)
    tex, uniforms = program.shadow_maps(meshes, vao_gt, count, lights)
    vectors = np.array([(*light.vector, 1.0 if light.point else 0.0) for light in lights],
                       dtype=np.float32)
    return LitScene(vao, own, tex, float(ambient), vectors,
                    np.array([light.intensity for light in lights], dtype=np.float32),
                    materials=[m.material for m in meshes], **uniforms)


def release_lit(lit: LitScene) -> None:
    from OpenGL import GL

    GL.glDeleteVertexArrays(1, [lit.vao])
    GL.glDeleteBuffers(1, [lit.vbo])
    GL.glDeleteTextures(1, [lit.shadow_texture])
