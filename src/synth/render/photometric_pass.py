"""The photometric models' gamma, gain and bias, noise and rounding of blurred colour views in a
GL pass (:func:`synth.appearance.photometric.sensor_shader`), the same bytes as the CPU.

The power of ~1.5 M float32 values per blurred 960x540 view is the dearest of the models on the
CPU (~6 ms a view); on a GPU it is a fragment pass. The shader repeats the CPU path's float32
and float64 operations in their order (``precise``, explicit ``fma``), on the noise words the
CPU draws; GLSL leaves some of that to the implementation (the rounding of ``fma``, a
compiler's freedom with an expression), so :func:`open_sensor_pass` runs a reference view
through the pass and the CPU path and returns the pass only where every byte agrees. A value
off ``powf``'s fast path (extreme gammas of near-black values) sends its view back to the CPU.

On llvmpipe the pass costs more than the CPU path it replaces (measured: 18 ms against 7 ms
per 960x540 view for the power alone), so :class:`synth.render.Renderer` uses it on hardware
renderers only unless asked.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from stereoforge.validation import check_choice
from synth.render.passes import compile_program, delete_framebuffer, framebuffer

__all__ = ["PHOTOMETRIC_ENGINES", "SOFTWARE_RENDERERS", "SensorPass", "check_photometric_engine",
           "open_sensor_pass"]

#: The values of :class:`synth.render.Renderer`'s ``photometric``.
PHOTOMETRIC_ENGINES = ("auto", "gl", "cpu")

#: Words of a ``GL_RENDERER`` string that name a rasterizer running on the CPU, where the pass
#: costs more than the CPU path (``Renderer(photometric="auto")`` does not use it there).
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "software")

_VERT = """#version 400 core
void main() {  // one triangle over the viewport
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""
_QUANTILES = 256  # the 65536-entry noise table as a 256 x 256 texture


def check_photometric_engine(value: object, name: str = "photometric") -> str:
    """``value`` if it is one of :data:`PHOTOMETRIC_ENGINES`, else a ``ParameterError`` (a
    ``ValueError``) naming them."""
    return check_choice(value, name, PHOTOMETRIC_ENGINES,
                        fix="auto: the GL pass on a GPU, the CPU on a software renderer; the "
                            "same bytes either way")


class SensorPass:
    """The sensor shader, its textures and its ``RGBA8UI`` framebuffer (one size at a time).

    :meth:`sensor` is :class:`synth.appearance.photometric.SensorOffload`'s method. Use
    :func:`open_sensor_pass`, which checks the pass against the CPU first.
    """

    def __init__(self, make_current: Callable[[], None]) -> None:
        from OpenGL import GL

        from synth.appearance.photometric import sensor_shader

        self.make_current = make_current  # the pass's context, before each use
        self.program = compile_program(_VERT, sensor_shader())
        self.loc = {name: GL.glGetUniformLocation(self.program, name)
                    for name in ("use_gamma", "use_noise", "gamma", "pre", "gain", "bias")}
        GL.glUseProgram(self.program)
        for unit, name in enumerate(("image", "words", "quantiles")):
            GL.glUniform1i(GL.glGetUniformLocation(self.program, name), unit)
        GL.glUseProgram(0)
        self.vao = int(GL.glGenVertexArrays(1))
        self.quantiles = self._new_texture(GL.GL_R32F, _QUANTILES, _QUANTILES)
        self.table_key: bytes | None = None  # the quantiles uploaded
        self.size: tuple[int, int] | None = None
        self.image = self.words = 0
        self.fb: tuple[int, list[int]] | None = None

    @staticmethod
    def _new_texture(fmt: int, width: int, height: int) -> int:
        from OpenGL import GL

        tex = int(GL.glGenTextures(1))
        GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
        GL.glTexStorage2D(GL.GL_TEXTURE_2D, 1, fmt, width, height)
        for pname in (GL.GL_TEXTURE_MIN_FILTER, GL.GL_TEXTURE_MAG_FILTER):
            GL.glTexParameteri(GL.GL_TEXTURE_2D, pname, GL.GL_NEAREST)
        GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
        return tex

    def _resize(self, width: int, height: int) -> None:
        from OpenGL import GL

        self._free_sized()
        self.image = self._new_texture(GL.GL_RGB32F, width, height)
        self.words = self._new_texture(GL.GL_RGB16UI, width, height)
        self.fb = framebuffer([(GL.GL_COLOR_ATTACHMENT0, GL.GL_RGBA8UI)], width, height, 1,
                              "sensor pass")
        self.size = (width, height)

    def _free_sized(self) -> None:
        from OpenGL import GL

        if self.fb is not None:
            delete_framebuffer(self.fb)
            GL.glDeleteTextures(2, [self.image, self.words])
            self.fb, self.size = None, None

    def delete(self) -> None:
        """Free the pass's GL objects (the context must be current)."""
        from OpenGL import GL

        self._free_sized()
        GL.glDeleteTextures(1, [self.quantiles])
        GL.glDeleteVertexArrays(1, [self.vao])
        GL.glDeleteProgram(self.program)

    def sensor(self, image: np.ndarray, *, gamma: float, gain: float, bias: float,
               quantiles: np.ndarray | None, words: np.ndarray | None) -> np.ndarray | None:
        """(H, W, 3) uint8: ``image`` (float32, C-contiguous) through steps 2-5 of the
        photometric models, as :mod:`synth.appearance.photometric` computes them on the CPU;
        ``None`` where a value left ``powf``'s fast path (the CPU then redoes the view)."""
        from OpenGL import GL

        self.make_current()
        h, w = image.shape[:2]
        if self.size != (w, h):
            self._resize(w, h)
        noise = words is not None
        GL.glActiveTexture(GL.GL_TEXTURE0)
        GL.glBindTexture(GL.GL_TEXTURE_2D, self.image)
        GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, w, h, GL.GL_RGB, GL.GL_FLOAT,
                           np.ascontiguousarray(image, dtype=np.float32))
        if noise:
            GL.glActiveTexture(GL.GL_TEXTURE1)
            GL.glBindTexture(GL.GL_TEXTURE_2D, self.words)
            GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, w, h, GL.GL_RGB_INTEGER,
                               GL.GL_UNSIGNED_SHORT, np.ascontiguousarray(words, np.uint16))
            table = np.ascontiguousarray(quantiles, np.float32)
            GL.glActiveTexture(GL.GL_TEXTURE2)
            GL.glBindTexture(GL.GL_TEXTURE_2D, self.quantiles)
            key = table.tobytes()
            if key != self.table_key:  # one table per noise sigma: left and right share it
                GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, _QUANTILES, _QUANTILES,
                                   GL.GL_RED, GL.GL_FLOAT, table)
                self.table_key = key
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self.fb[0])
        GL.glViewport(0, 0, w, h)
        for cap in (GL.GL_DEPTH_TEST, GL.GL_CULL_FACE, GL.GL_BLEND, GL.GL_MULTISAMPLE,
                    GL.GL_DITHER):
            GL.glDisable(cap)
        GL.glUseProgram(self.program)
        loc = self.loc
        GL.glUniform1i(loc["use_gamma"], int(gamma != 1.0))
        GL.glUniform1i(loc["use_noise"], int(noise))
        GL.glUniform1f(loc["gamma"], np.float32(gamma))
        GL.glUniform1f(loc["pre"], np.float32(1.0 / 255.0))
        GL.glUniform1f(loc["gain"], np.float32(gain))
        GL.glUniform1f(loc["bias"], np.float32(bias))
        GL.glBindVertexArray(self.vao)
        GL.glDrawArrays(GL.GL_TRIANGLES, 0, 3)
        GL.glBindVertexArray(0)
        GL.glUseProgram(0)
        out = np.empty((h, w, 4), np.uint8)
        GL.glReadBuffer(GL.GL_COLOR_ATTACHMENT0)
        GL.glReadPixels(0, 0, w, h, GL.GL_RGBA_INTEGER, GL.GL_UNSIGNED_BYTE, out.ctypes.data)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        for unit in (2, 1, 0):
            GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
            GL.glBindTexture(GL.GL_TEXTURE_2D, 0)
        if out[..., 3].any():
            return None
        return cv2.cvtColor(out, cv2.COLOR_RGBA2RGB)


def _reference_views() -> tuple[np.ndarray, np.ndarray]:
    """A 96 x 64 colour pair whose blurred values cover black, near-black, mid and white levels
    and their edges (uint8, fixed)."""
    rng = np.random.default_rng(20261205)
    left = rng.integers(0, 256, (64, 96, 3), dtype=np.uint8)
    left[:8] = 0
    left[8:16] = rng.integers(0, 3, (8, 96, 3), dtype=np.uint8)
    left[16:24] = 255
    right = np.roll(left, 5, axis=1)
    return left, right


def open_sensor_pass(make_current: Callable[[], None]) -> tuple[SensorPass | None, str]:
    """A :class:`SensorPass` on the context that ``make_current`` makes current and ``""``, or
    ``None`` and the reason:
    the shader does not compile here, or its bytes differ from the CPU path's on a reference
    pair (several gammas, gains, biases, noise levels and blurs)."""
    from synth.appearance.photometric import PhotometricParams, apply_photometric

    try:
        sensor = SensorPass(make_current)
    except Exception as exc:  # no GLSL 4.00 doubles, a driver's compiler error
        return None, f"the sensor shader does not compile here: {type(exc).__name__}"
    left, right = _reference_views()
    cases = [PhotometricParams(blur_sigma=1.0, gamma=0.83, gain=1.07, bias=-3.3,
                               noise_sigma=2.5),
             PhotometricParams(blur_sigma=0.5, gamma=1.21, gain=0.93, bias=6.1),
             PhotometricParams(blur_sigma=2.0, noise_sigma=4.0, gain=1.02, bias=0.4),
             PhotometricParams(blur_sigma=0.7, gamma=3.7, noise_sigma=0.5)]
    declined = []

    class _Counted:  # the CPU's fallback must not stand in for the pass here
        def sensor(self, image: np.ndarray, **kwargs: object) -> np.ndarray | None:
            out = sensor.sensor(image, **kwargs)
            declined.append(out is None)
            return out

    reason = ""
    try:
        for i, params in enumerate(cases):
            cpu = apply_photometric(left, right, params, rng=i)
            gl = apply_photometric(left, right, params, rng=i, offload=_Counted())
            if any(declined) or not (np.array_equal(cpu.left, gl.left)
                                     and np.array_equal(cpu.right, gl.right)):
                reason = "the sensor shader's bytes differ from the CPU's on this driver"
                break
    except Exception as exc:  # a driver's error at the first draw
        reason = f"the sensor shader failed on this driver ({type(exc).__name__}: {exc})"
    if reason:
        sensor.delete()
        return None, reason
    return sensor, ""
