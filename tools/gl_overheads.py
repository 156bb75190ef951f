"""What one GL call group costs the CPU on this machine's driver: the figures that decide whether
moving a CPU stage into GL passes pays (a texture's synthesis, a sensor model).

    python tools/gl_overheads.py [--backend egl|osmesa] [--repeat N]

Each row times ``N`` repetitions of one operation on a 768x576 texture (the size of `flying`'s
background wall), in wall and CPU time of this process (all its threads, the driver's included):

- ``finish``: ``glFinish`` with nothing to do (a round trip to the driver);
- ``dispatch``: a compute dispatch as a texture pass would issue it (program, two uniforms, the
  image binding, one 16x16 workgroup per tile, a memory barrier), ``glFinish`` every 8;
- ``dispatch+finish``: the same, waiting for each;
- ``upload``: ``glTexSubImage2D`` of the RGBA8 texels from a numpy array, then ``glFinish``;
- ``mipmap``: ``glGenerateMipmap`` of the texture, then ``glFinish``;
- ``readback``: ``glGetTexImage`` of level 0 into a numpy array.

On llvmpipe the GL work is CPU work of the same cores; on a GPU the CPU figures are the price of
issuing the work (and of the driver's wait for the GPU: NVIDIA's spins unless ``__GL_YIELD`` is
``USLEEP``). Run by ``tools/gpu_check.sh``; nothing here is part of the package.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

W, H = 768, 576

_COMPUTE = """#version 430
layout(local_size_x = 16, local_size_y = 16) in;
layout(rgba8ui, binding = 0) uniform writeonly uimage2D target;
uniform uint seed;
uniform int level;
void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= imageSize(target).x || p.y >= imageSize(target).y) return;
    uint h = (uint(p.x) * 73856093u) ^ (uint(p.y) * 19349663u) ^ seed;
    h ^= h >> 16; h *= 0x7feb352du; h ^= h >> 15;
    imageStore(target, p, uvec4(h & 255u, (h >> 8) & 255u, (h >> 16) & 255u, uint(level)));
}
"""


def _timed(run, repeat: int) -> tuple[float, float]:
    """Microseconds of wall and CPU time per repetition."""
    wall, cpu = time.perf_counter(), time.process_time()
    run(repeat)
    return (1e6 * (time.perf_counter() - wall) / repeat,
            1e6 * (time.process_time() - cpu) / repeat)


def measure(backend: str, repeat: int) -> tuple[str, list[tuple[str, float, float]]]:
    from synth.render.renderer import Renderer

    rows: list[tuple[str, float, float]] = []
    with Renderer(64, 48, backend=backend) as renderer:  # first: it picks PyOpenGL's platform
        from OpenGL import GL
        from OpenGL.GL import shaders

        name = f"{renderer.gl_renderer} | {renderer.gl_version}"
        program = shaders.compileProgram(shaders.compileShader(_COMPUTE, GL.GL_COMPUTE_SHADER))
        seed = GL.glGetUniformLocation(program, "seed")
        level = GL.glGetUniformLocation(program, "level")
        texels = np.random.default_rng(0).integers(0, 256, (H, W, 4), dtype=np.uint8)
        textures = GL.glGenTextures(2)
        for texture, internal in zip(textures, (GL.GL_RGBA8UI, GL.GL_RGBA8)):
            GL.glBindTexture(GL.GL_TEXTURE_2D, texture)
            GL.glTexStorage2D(GL.GL_TEXTURE_2D, 10, internal, W, H)
        GL.glBindTexture(GL.GL_TEXTURE_2D, textures[1])
        GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, W, H, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, texels)
        GL.glFinish()

        def finish(n: int) -> None:
            for _ in range(n):
                GL.glFinish()

        def dispatch(n: int, every: int = 8) -> None:
            for i in range(n):
                GL.glUseProgram(program)
                GL.glUniform1ui(seed, i)
                GL.glUniform1i(level, 0)
                GL.glBindImageTexture(0, textures[0], 0, GL.GL_FALSE, 0, GL.GL_WRITE_ONLY,
                                      GL.GL_RGBA8UI)
                GL.glDispatchCompute((W + 15) // 16, (H + 15) // 16, 1)
                GL.glMemoryBarrier(GL.GL_SHADER_IMAGE_ACCESS_BARRIER_BIT)
                if (i + 1) % every == 0:
                    GL.glFinish()
            GL.glFinish()

        def upload(n: int) -> None:
            GL.glBindTexture(GL.GL_TEXTURE_2D, textures[1])
            for _ in range(n):
                GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, W, H, GL.GL_RGBA,
                                   GL.GL_UNSIGNED_BYTE, texels)
                GL.glFinish()

        def mipmap(n: int) -> None:
            GL.glBindTexture(GL.GL_TEXTURE_2D, textures[1])
            for _ in range(n):
                GL.glGenerateMipmap(GL.GL_TEXTURE_2D)
                GL.glFinish()

        out = np.empty((H, W, 4), np.uint8)

        def readback(n: int) -> None:
            GL.glBindTexture(GL.GL_TEXTURE_2D, textures[1])
            for _ in range(n):
                GL.glGetTexImage(GL.GL_TEXTURE_2D, 0, GL.GL_RGBA, GL.GL_UNSIGNED_BYTE, out)

        dispatch(4)  # compile and warm
        for label, run, n in (("finish", finish, 10 * repeat), ("dispatch", dispatch, repeat),
                              ("dispatch+finish", lambda k: dispatch(k, every=1), repeat),
                              ("upload", upload, repeat), ("mipmap", mipmap, repeat),
                              ("readback", readback, repeat)):
            rows.append((label, *_timed(run, n)))
        if not np.array_equal(out, texels):  # the readback read what was uploaded
            raise RuntimeError("the texture read back differs from the one uploaded")
        GL.glDeleteTextures(textures)
        GL.glDeleteProgram(program)
    return name, rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="egl", choices=("egl", "osmesa"))
    parser.add_argument("--repeat", type=int, default=50)
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error("--repeat must be >= 1")
    name, rows = measure(args.backend, args.repeat)
    print(f"GL: {name} ({args.backend}); {W}x{H} RGBA8, {args.repeat} repetitions\n")
    print("| operation | wall us | CPU us |")
    print("|---|---|---|")
    for label, wall, cpu in rows:
        print(f"| {label} | {wall:.1f} | {cpu:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
