"""GLSL the colour shaders share: a texture lookup at a mip level of our own.

``texture()`` leaves the level to the driver: GL (4.6, section 8.14.1) lets an implementation
approximate the scale factor rho, and its derivatives may be coarse or fine. On two GL
implementations of one machine (Mesa's llvmpipe and softpipe) that choice alone moved the golden
``flying`` colours by a mean of 1.4 and a p99 of 9-12 grey levels. :data:`TEXTURE_LOD` computes
the level itself, ``log2 rho`` with the specification's exact rho (the longer of the screen
derivatives of the texel coordinates), from fine derivatives where the driver has them
(``ARB_derivative_control``: llvmpipe, softpipe and NVIDIA's driver do), and samples it with
``textureLod`` and the sampler's trilinear filter. Between llvmpipe and softpipe the golden
scenes then differ by the filters' arithmetic only (mean 0.3, p99 1; docs/ground-truth.md,
tests/synth/test_render_drivers.py).

A shader using it starts with :data:`HEADER` (the extension directive must precede any
declaration) and calls ``texture_lod(sampler, uv)`` in uniform control flow (the derivatives
need the whole 2x2 quad).
"""

from __future__ import annotations

__all__ = ["HEADER", "TEXTURE_LOD"]

#: The first lines of a fragment shader that uses :data:`TEXTURE_LOD`.
HEADER = """#version 330 core
#extension GL_ARB_derivative_control : enable
"""

#: ``vec4 texture_lod(sampler2D t, vec2 uv)``: ``textureLod`` at our own level of ``uv``.
TEXTURE_LOD = """
vec4 texture_lod(sampler2D t, vec2 coord) {
    vec2 size = vec2(textureSize(t, 0));
#ifdef GL_ARB_derivative_control
    vec2 dx = dFdxFine(coord) * size, dy = dFdyFine(coord) * size;
#else
    vec2 dx = dFdx(coord) * size, dy = dFdy(coord) * size;
#endif
    return textureLod(t, coord, 0.5 * log2(max(dot(dx, dx), dot(dy, dy))));
}
"""
