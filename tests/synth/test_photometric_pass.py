"""The photometric models' GL pass (:mod:`synth.render.photometric_pass`): the CPU's bytes.

The pass runs the gamma, gain and bias, noise and rounding of blurred colour views in a fragment
shader; it is a speed lever for GPUs and must never change a byte. These tests run it on the
test machine's Mesa (``photometric="gl"``, which ``"auto"`` does not choose on a software
renderer) against the CPU path: random and hand-made values, the rounding ties where a
multiply-add computed as two roundings differs, the view that leaves ``powf``'s fast path, and
whole dataset samples.
"""

from __future__ import annotations

import filecmp
from pathlib import Path

import cv2
import numpy as np
import pytest

import synth.appearance.photometric as photometric
from synth.appearance.photometric import PhotometricParams, apply_photometric
from synth.render.photometric_pass import SOFTWARE_RENDERERS, open_sensor_pass
from synth.render.renderer import Renderer

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def gl_renderer(renderer):
    """A renderer whose photometric models run in the GL pass (the session's backend)."""
    with Renderer(64, 48, backend=renderer.backend, photometric="gl") as r:
        assert r.photometric_engine == "gl", r.photometric_engine
        yield r


class _Counting:
    """An offload that counts the views the pass did (and those it sent back to the CPU)."""

    def __init__(self, inner) -> None:
        self.inner, self.done, self.declined = inner, 0, 0

    def sensor(self, image, **kwargs):
        out = self.inner.sensor(image, **kwargs)
        self.done += out is not None
        self.declined += out is None
        return out


def _views(shape: tuple[int, int], seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A textured colour pair with black, near-black and white bands (uint8)."""
    rng = np.random.default_rng(seed)
    left = cv2.GaussianBlur(rng.integers(0, 256, (*shape, 3), dtype=np.uint8), (0, 0), 1.5)
    left[: shape[0] // 8] = 0
    left[shape[0] // 8: shape[0] // 4] = rng.integers(0, 3, (shape[0] // 4 - shape[0] // 8,
                                                             shape[1], 3), dtype=np.uint8)
    left[-shape[0] // 8:] = 255
    return left, np.roll(left, 9, axis=1)


CASES = [
    PhotometricParams(blur_sigma=1.0, gamma=0.83, gain=1.07, bias=-3.3, noise_sigma=2.5,
                      jpeg_quality=90),
    PhotometricParams(blur_sigma=0.5, gamma=1.21, gain=0.93, bias=6.1),
    PhotometricParams(blur_sigma=2.0, noise_sigma=4.0, gain=1.02, bias=0.4),  # no gamma
    PhotometricParams(blur_sigma=0.7, gamma=2.9, noise_sigma=0.25, gain=3.9, bias=-128.0),
    PhotometricParams(blur_sigma=16.0, gamma=0.1, noise_sigma=64.0, gain=0.01, bias=128.0),
]


@pytest.mark.parametrize("params", CASES, ids=range(len(CASES)))
@pytest.mark.parametrize("shape", [(48, 64), (540, 960)])
def test_the_pass_gives_the_cpus_bytes(gl_renderer, params, shape) -> None:
    left, right = _views(shape, seed=shape[0])
    offload = _Counting(gl_renderer.sensor_pass)
    cpu = apply_photometric(left, right, params, rng=7)
    gl = apply_photometric(left, right, params, rng=7, offload=offload)
    assert offload.done == 2 and offload.declined == 0  # the pass did both views
    assert np.array_equal(cpu.left, gl.left) and np.array_equal(cpu.right, gl.right)


def test_multiply_add_ties_are_rounded_once(gl_renderer) -> None:
    """``rint(fma(x, gain, noise + bias))`` where the product rounded first would land on the
    other side of a half (llvmpipe computes GLSL's ``fma`` so; the shader's own does not)."""
    rng = np.random.default_rng(3)
    gain, bias = np.float32(1.0370001), np.float32(0.0)
    x = rng.uniform(0.0, 250.0, 4_000_000).astype(np.float32)
    noise = rng.uniform(-4.0, 4.0, x.size).astype(np.float32)
    exact = x.astype(np.float64) * np.float64(gain) + noise.astype(np.float64)  # exact here
    twice = (x * gain).astype(np.float32) + noise
    ties = np.flatnonzero(np.rint(exact.astype(np.float32)) != np.rint(twice))
    ties = ties[: ties.size - ties.size % 3]  # whole pixels
    assert 3 <= ties.size < 1 << 16  # the values where one rounding and two differ
    table = np.zeros(1 << 16, np.float32)
    table[: ties.size] = noise[ties]  # value i reads word i: its own noise
    image = np.ascontiguousarray(x[ties].reshape(1, -1, 3))
    words = np.arange(ties.size, dtype=np.uint16)
    out = gl_renderer.sensor_pass.sensor(image, gamma=1.0, gain=float(gain), bias=float(bias),
                                         quantiles=table, words=words)
    cpu = photometric._noisy_words(image, None, float(gain), float(bias), table, words)
    assert out is not None and np.array_equal(out, cpu)


_POWF_FRAG = """#version 400 core
uniform sampler2D x;
uniform float y;
layout(location = 0) out vec4 out_value;
%s
void main() {
    bool fast;
    float v = powf_fast(texelFetch(x, ivec2(gl_FragCoord.xy), 0).r, y, fast);
    out_value = vec4(v, fast ? 0.0 : 1.0, 0.0, 0.0);
}
"""
_VERT = """#version 400 core
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""


def _gl_powf(renderer: Renderer, x: np.ndarray, y: float) -> tuple[np.ndarray, np.ndarray]:
    """The shader's ``powf_fast`` of an (H, W) float32 array: values and the fast-path mask."""
    from OpenGL import GL

    from synth.appearance._powf import glsl_powf
    from synth.render.passes import compile_program, delete_framebuffer, framebuffer

    renderer._context.make_current()
    h, w = x.shape
    program = compile_program(_VERT, _POWF_FRAG % glsl_powf())
    tex = GL.glGenTextures(1)
    GL.glBindTexture(GL.GL_TEXTURE_2D, tex)
    GL.glTexStorage2D(GL.GL_TEXTURE_2D, 1, GL.GL_R32F, w, h)
    GL.glTexSubImage2D(GL.GL_TEXTURE_2D, 0, 0, 0, w, h, GL.GL_RED, GL.GL_FLOAT,
                       np.ascontiguousarray(x))
    fb = framebuffer([(GL.GL_COLOR_ATTACHMENT0, GL.GL_RGBA32F)], w, h, 1, "powf test")
    vao = GL.glGenVertexArrays(1)
    try:
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fb[0])
        GL.glViewport(0, 0, w, h)
        GL.glUseProgram(program)
        GL.glUniform1f(GL.glGetUniformLocation(program, "y"), np.float32(y))
        GL.glBindVertexArray(vao)
        GL.glDrawArrays(GL.GL_TRIANGLES, 0, 3)
        out = np.empty((h, w, 4), np.float32)
        GL.glReadPixels(0, 0, w, h, GL.GL_RGBA, GL.GL_FLOAT, out.ctypes.data)
    finally:
        GL.glBindVertexArray(0)
        GL.glUseProgram(0)
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
        GL.glDeleteVertexArrays(1, [vao])
        GL.glDeleteTextures(1, [tex])
        delete_framebuffer(fb)
        GL.glDeleteProgram(program)
    return out[..., 0], out[..., 1] == 0


def test_the_shaders_power_is_glibcs_to_the_bit(gl_renderer) -> None:
    """``powf_fast`` against the CPU's port of glibc's ``powf`` on float32 values (not rounded
    to grey levels): every exponent and mantissa of (0, 1], and the value whose last bit
    llvmpipe's GLSL ``fma`` (a product and a sum, each rounded) got wrong in 74 M tried."""
    from synth.appearance._powf import powf

    rng = np.random.default_rng(5)
    bits = rng.integers(0x00800000, 0x3F800001, (256, 1024), dtype=np.uint32)
    for x, y in ((bits.view(np.float32), 0.45), (bits.view(np.float32), 2.2),
                 (np.full((4, 4), 0.66792005, np.float32), 0.6484226)):
        y = float(np.float32(y))
        values, fast = _gl_powf(gl_renderer, x, y)
        reference = powf(x, y)
        assert fast.mean() > 0.4  # tiny values to the power 2.2 leave the fast path
        assert np.array_equal(values[fast].view(np.uint32), reference[fast].view(np.uint32))


def test_a_view_off_the_fast_path_goes_back_to_the_cpu(gl_renderer) -> None:
    """Near-black values to a power of 10 leave ``powf``'s fast path (``|y log2 x| >= 126``):
    the pass declines the view and the CPU redoes it with the same noise words."""
    left = np.zeros((24, 32, 3), np.uint8)
    left[::4, ::4] = 1  # blurred: values ~1e-3 grey levels
    left[12:] = 200
    right = np.roll(left, 3, axis=1)
    params = PhotometricParams(blur_sigma=1.0, gamma=10.0, noise_sigma=1.5, gain=1.1, bias=2.0)
    offload = _Counting(gl_renderer.sensor_pass)
    gl = apply_photometric(left, right, params, rng=4, offload=offload)
    cpu = apply_photometric(left, right, params, rng=4)
    assert offload.declined == 2 and offload.done == 0
    assert np.array_equal(cpu.left, gl.left) and np.array_equal(cpu.right, gl.right)


def test_grey_views_and_unblurred_views_stay_on_the_cpu(gl_renderer) -> None:
    left, right = _views((32, 48), seed=1)
    offload = _Counting(gl_renderer.sensor_pass)
    grey = [cv2.cvtColor(v, cv2.COLOR_RGB2GRAY) for v in (left, right)]
    blurred = PhotometricParams(blur_sigma=1.0, gamma=1.1, noise_sigma=1.0)
    sharp = PhotometricParams(gamma=1.1, noise_sigma=1.0)
    for images, params in ((grey, blurred), ((left, right), sharp)):
        assert all(np.array_equal(a, b) for a, b in zip(
            apply_photometric(*images, params, rng=0),
            apply_photometric(*images, params, rng=0, offload=offload)))
    assert offload.done == offload.declined == 0


def test_where_the_renderer_runs_the_models(renderer) -> None:
    with Renderer(32, 24, backend=renderer.backend, photometric="cpu") as r:
        assert r.sensor_pass is None and r.photometric_engine == "cpu (asked for)"
    with Renderer(32, 24, backend=renderer.backend) as r:  # auto: the pass on a GPU only
        software = any(word in r.gl_renderer.lower() for word in SOFTWARE_RENDERERS)
        if software:
            assert r.sensor_pass is None and r.photometric_engine == "cpu (a software renderer)"
        else:
            assert r.photometric_engine == "gl" or r.photometric_engine.startswith(
                "cpu (the sensor shader")
    with pytest.raises(ValueError,
                       match=r"photometric: expected one of \['auto', 'gl', 'cpu'\], got 'gpu'"):
        Renderer(32, 24, backend=renderer.backend, photometric="gpu")


def test_a_shader_that_differs_or_does_not_compile_is_not_used(renderer, monkeypatch) -> None:
    """The start-up check: a shader whose bytes differ from the CPU's (here: off by one grey
    level without noise) or that does not compile (softpipe has no double precision) leaves the
    models on the CPU, with the reason."""
    shader = photometric.sensor_shader()
    wrong = shader.replace("q = roundEven(mb);", "q = roundEven(mb) + 1.0;")
    assert wrong != shader
    monkeypatch.setattr(photometric, "sensor_shader", lambda: wrong)
    with Renderer(32, 24, backend=renderer.backend, photometric="gl") as r:
        assert r.sensor_pass is None
        assert r.photometric_engine == ("cpu (the sensor shader's bytes differ from the CPU's "
                                        "on this driver)")
    monkeypatch.setattr(photometric, "sensor_shader", lambda: "#version 400 core\nbroken")
    with Renderer(32, 24, backend=renderer.backend) as r:
        r._context.make_current()
        sensor, reason = open_sensor_pass(r._context.make_current)
        assert sensor is None and reason.startswith("the sensor shader does not compile here")


def test_dataset_samples_are_byte_identical(tmp_path: Path, renderer, gl_renderer) -> None:
    """Whole `flying` samples (blurred, gamma, noise, gain and bias, JPEG) written by a renderer
    with the pass and one without: every file the same."""
    from synth.dataset.config.parse import load_config, resized
    from synth.dataset.config.sampling import draw_sample
    from synth.dataset.sample import produce_sample

    cfg = resized(load_config("flying"), 160, 120)
    blurred = [i for i in range(40) if draw_sample(cfg, i).photometric.blur_sigma > 0][:3]
    assert len(blurred) == 3
    with Renderer(160, 120, backend=renderer.backend, photometric="cpu") as cpu:
        for i in blurred:
            produce_sample(cfg, i, cpu, tmp_path / "cpu" / f"{i:06d}", "middlebury")
    offload = _Counting(gl_renderer.sensor_pass)
    gl_renderer._sensor = offload  # count the views the pass does inside produce_sample
    try:
        for i in blurred:
            produce_sample(cfg, i, gl_renderer, tmp_path / "gl" / f"{i:06d}", "middlebury")
    finally:
        gl_renderer._sensor = offload.inner
    assert offload.done >= 2 * len(blurred)
    compared = filecmp.dircmp(tmp_path / "cpu", tmp_path / "gl")
    assert not compared.left_only and not compared.right_only
    for i in blurred:
        names = sorted(p.name for p in (tmp_path / "cpu" / f"{i:06d}").iterdir())
        assert "im0.png" in names
        match, mismatch, errors = filecmp.cmpfiles(tmp_path / "cpu" / f"{i:06d}",
                                                   tmp_path / "gl" / f"{i:06d}", names,
                                                   shallow=False)
        assert not mismatch and not errors, (i, mismatch, errors)
