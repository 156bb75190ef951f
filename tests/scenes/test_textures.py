"""Procedural textures: determinism, contrast, frequency, shapes and errors."""

from __future__ import annotations

import numpy as np
import pytest

from scenes.spec import TextureSpec
from scenes.textures import (
    MAX_TEXTURE_SIDE,
    NOISE_BAND,
    band_limited_noise,
    make_texture,
    texture_image,
    texture_shape,
)


def _dominant_frequency(grey: np.ndarray, extent: tuple[float, float]) -> float:
    """Radius (cycles per metre) of the peak of the radially averaged power spectrum."""
    h, w = grey.shape
    power = np.abs(np.fft.fft2(grey - grey.mean())) ** 2
    fu = np.fft.fftfreq(w, d=extent[0] / w)
    fv = np.fft.fftfreq(h, d=extent[1] / h)
    radius = np.hypot(fv[:, None], fu[None, :]).ravel()
    step = 1.0 / max(extent)
    bins = np.rint(radius / step).astype(int)
    mean_power = np.bincount(bins, power.ravel()) / np.maximum(np.bincount(bins), 1)
    return float(np.argmax(mean_power) * step)


@pytest.mark.parametrize(("frequency", "extent"), [(4.0, (2.0, 2.0)), (10.0, (1.5, 1.0)),
                                                     (25.0, (1.0, 0.5))])
def test_noise_dominant_frequency_matches_request(frequency: float, extent) -> None:
    img = make_texture(TextureSpec(frequency=frequency, contrast=1.0, seed=3), extent=extent)
    measured = _dominant_frequency(img[:, :, 0].astype(float), extent)
    assert abs(measured - frequency) <= 0.25 * frequency


@pytest.mark.parametrize(("kind", "angle", "axis"), [("stripes", 0.0, "u"), ("stripes", 90.0, "v"),
                                                       ("checker", 0.0, "both")])
def test_periodic_patterns_have_the_requested_period(kind: str, angle: float, axis: str) -> None:
    frequency, extent = 5.0, (2.0, 2.0)  # 10 periods over 2 m
    grey = make_texture(TextureSpec(kind=kind, frequency=frequency, contrast=1.0, angle=angle),
                        extent=extent)[:, :, 0].astype(float)
    h, w = grey.shape
    spec_u = np.abs(np.fft.rfft(grey, axis=1)).sum(0)  # variation along u (across columns)
    spec_v = np.abs(np.fft.rfft(grey, axis=0)).sum(1)
    spec_u[0] = spec_v[0] = 0.0  # ignore the means
    if axis == "u":
        assert np.argmax(spec_u) == 10 and spec_v.max() < 1e-6 * spec_u.max()
    elif axis == "v":
        assert np.argmax(spec_v) == 10 and spec_u.max() < 1e-6 * spec_v.max()
    else:  # checker: product of two square waves, odd harmonics combine at (10, 10)
        power = np.abs(np.fft.fft2(grey - grey.mean()))
        i, j = np.unravel_index(np.argmax(power), power.shape)
        assert (min(i, h - i), min(j, w - j)) == (10, 10)


def test_stripes_angle_rotates_the_pattern() -> None:
    grey = make_texture(TextureSpec(kind="stripes", frequency=4.0, contrast=1.0, angle=45.0),
                        extent=(1.0, 1.0))[:, :, 0].astype(int)
    # constant along the direction (1, -1) in (u, v): shifting down one row and left one column
    np.testing.assert_array_equal(grey[1:, :-1], grey[:-1, 1:])
    assert grey.std() > 50


def test_same_seed_same_bytes_other_seed_differs() -> None:
    for kind in ("noise", "checker", "stripes"):
        spec = TextureSpec(kind=kind, frequency=12.0, seed=5)
        a = make_texture(spec, extent=(1.0, 0.5))
        b = make_texture(TextureSpec(kind=kind, frequency=12.0, seed=5), extent=(1.0, 0.5))
        c = make_texture(TextureSpec(kind=kind, frequency=12.0, seed=6), extent=(1.0, 0.5))
        assert a.tobytes() == b.tobytes()
        assert a.tobytes() != c.tobytes()


@pytest.mark.parametrize("kind", ["noise", "checker", "stripes", "constant"])
def test_contrast_zero_or_constant_kind_gives_a_flat_image(kind: str) -> None:
    spec = TextureSpec(kind=kind, contrast=0.0 if kind != "constant" else 1.0, mean=0.3,
                       color=(1.0, 0.5, 0.0), frequency=10.0)
    img = make_texture(spec, extent=(1.0, 1.0))
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    expected = np.rint(255 * 0.3 * np.array([1.0, 0.5, 0.0]))
    np.testing.assert_array_equal(img.reshape(-1, 3), np.broadcast_to(expected, (img.size // 3, 3)))


def test_contrast_scales_amplitude_around_mean() -> None:
    stds, means = [], []
    for contrast in (0.2, 0.4, 0.8):
        grey = make_texture(TextureSpec(kind="checker", frequency=4.0, contrast=contrast,
                                        mean=0.5), extent=(1.0, 1.0))[:, :, 0].astype(float)
        stds.append(grey.std())
        means.append(grey.mean())
        assert grey.min() >= np.floor(255 * (0.5 - contrast / 2))
        assert grey.max() <= np.ceil(255 * (0.5 + contrast / 2))
    np.testing.assert_allclose(np.array(stds) / stds[0], [1, 2, 4], rtol=0.02)
    np.testing.assert_allclose(means, 127.5, atol=2.5)


def test_full_contrast_noise_uses_the_range() -> None:
    grey = make_texture(TextureSpec(frequency=8.0, contrast=1.0), extent=(2.0, 2.0))[:, :, 0]
    assert grey.min() == 0 and grey.max() == 255
    assert abs(float(grey.mean()) - 127.5) < 3


def test_shape_follows_extent_and_sampling() -> None:
    checker = TextureSpec(kind="checker", frequency=10.0)
    assert texture_shape(checker, extent=(2.0, 1.0)) == (80, 160)  # 8 px per cycle
    # noise: 20/3 px per cycle (4 per period of 5/3 the frequency), sides rounded up to 5-smooth
    noise = TextureSpec(frequency=10.0)
    assert texture_shape(noise, extent=(2.0, 1.0)) == (72, 135)  # 66.7 -> 72, 133.3 -> 135
    assert make_texture(noise, extent=(2.0, 1.0)).shape == (72, 135, 3)
    assert make_texture(checker, extent=(2.0, 1.0), pixels_per_metre=20.0).shape == (20, 40, 3)
    assert make_texture(noise, extent=(2.0, 1.0), pixels_per_metre=25.5).shape == (27, 54, 3)
    assert texture_shape(checker, extent=(1.6, 0.8)) == (65, 129)  # never a power of two
    big = texture_shape(TextureSpec(kind="stripes", frequency=1000.0), extent=(3.0, 1.0))
    assert big == (683, MAX_TEXTURE_SIDE - 1)  # capped (and not 2048), aspect kept
    assert texture_shape(TextureSpec(frequency=1000.0), extent=(3.0, 1.0)) == (720, 2025)
    assert texture_shape(checker, extent=(1e-6, 1e-6)) == (3, 3)
    assert texture_shape(TextureSpec(kind="constant"), extent=(4.0, 1.0)) == (3, 6)


@pytest.mark.parametrize(("kwargs", "pattern"), [
    ({"extent": (0.0, 1.0)}, "extent must be two finite sizes > 0"),
    ({"extent": (1.0,)}, r"extent must be \(width, height\)"),
    ({"extent": (1.0, 1.0), "pixels_per_metre": -1.0}, "pixels_per_metre must be finite and > 0"),
    ({"extent": (1.0, 1.0), "max_side": 1}, "max_side must be >= 3"),
    ({"extent": (1.0, 1.0), "max_side": 2}, "max_side must be >= 3"),  # below the smallest side
])
def test_bad_arguments(kwargs: dict, pattern: str) -> None:
    with pytest.raises(ValueError, match=pattern):
        make_texture(TextureSpec(), **kwargs)
    with pytest.raises(TypeError, match="spec must be a TextureSpec"):
        make_texture("noise", extent=(1.0, 1.0))  # type: ignore[arg-type]


def test_band_limited_noise_is_normalised_and_periodic() -> None:
    noise = band_limited_noise((48, 64), frequency=6.0, pixel_size=(1 / 32, 1 / 32),
                               rng=np.random.default_rng(1))
    assert noise.dtype == np.float32
    assert abs(float(noise.mean(dtype=np.float64))) < 1e-6
    assert float(noise.std(dtype=np.float64)) == pytest.approx(1.0, rel=1e-5)
    # periodic: the wrap-around step is no larger than a typical interior step
    interior = np.abs(np.diff(noise, axis=1)).max()
    assert np.abs(noise[:, 0] - noise[:, -1]).max() <= interior


def test_band_limited_noise_has_no_power_outside_its_band() -> None:
    frequency, pixel = 6.0, 1 / 40  # 6.7 px per period; band up to 10 cycles, Nyquist 20
    noise = band_limited_noise((60, 80), frequency=frequency, pixel_size=(pixel, pixel),
                               rng=np.random.default_rng(4)).astype(np.float64)
    power = np.abs(np.fft.fft2(noise)) ** 2
    radius = np.hypot(np.fft.fftfreq(60, d=pixel)[:, None], np.fft.fftfreq(80, d=pixel)[None, :])
    outside = np.abs(radius - frequency) > NOISE_BAND * frequency / 3 + 1e-9
    assert outside.any() and (~outside).sum() > 50
    assert power[outside].sum() <= 1e-9 * power.sum()
    # the band's centre carries more power per bin than its flanks
    centre = np.abs(radius - frequency) <= frequency / 6
    flank = (np.abs(radius - frequency) > frequency / 2) & ~outside
    assert power[centre].mean() > 3 * power[flank].mean()


def test_band_limited_noise_is_zero_when_the_band_is_beyond_nyquist() -> None:
    noise = band_limited_noise((8, 8), frequency=100.0, pixel_size=(0.1, 0.1),
                               rng=np.random.default_rng(0))
    assert noise.dtype == np.float32 and not noise.any()


# ---------------------------------------------------------------------------- reference formulas
def reference_noise(shape: tuple[int, int], frequency: float, pixel_size: tuple[float, float],
                    rng: np.random.Generator) -> np.ndarray:
    """``band_limited_noise`` as its docstring says: the whole rfft grid, one ``irfft2``.

    ``band_limited_noise`` tests only the cells near the band and transforms only the columns
    that hold band cells; the bits (signed zeros included) must not change.
    """
    h, w = shape
    f32 = np.float32
    fu, fv = np.fft.rfftfreq(w, d=pixel_size[0]), np.fft.fftfreq(h, d=pixel_size[1])
    radius = np.hypot(fv[:, None], fu[None, :])
    sigma = frequency / 3.0
    band = np.abs(radius - frequency) <= NOISE_BAND * sigma
    band[0, 0] = False
    gain = np.exp(-0.5 * ((radius - frequency) / sigma) ** 2).astype(f32)
    re, im = rng.standard_normal((2, int(band.sum())), dtype=f32)
    spectrum = np.zeros(band.shape, dtype=np.complex64)
    spectrum[band] = re * gain[band] + 1j * (im * gain[band])
    noise = np.fft.irfft2(spectrum, s=(h, w))
    noise = (noise - noise.mean(dtype=np.float64)).astype(f32)
    std = np.sqrt(np.mean(noise**2, dtype=np.float64))
    return noise * f32(1.0 / std) if std > 0 else noise  # 0: no frequency of the band fits


def reference_annulus(h: int, w: int, frequency: float, du: float, dv: float
                      ) -> tuple[np.ndarray, np.ndarray, int]:
    """``_annulus`` as its docstring says: the band test on every cell of the rfft grid.

    ``_annulus`` tests only a window of columns per row; its cells, their order and the
    gains' bits must be these.
    """
    fu, fv = np.fft.rfftfreq(w, d=du), np.fft.fftfreq(h, d=dv)
    sigma = frequency / 3.0
    reach = (frequency + NOISE_BAND * sigma) * (1 + 1e-6)
    used = int(np.count_nonzero(fu <= reach))
    offset = np.hypot(fv[:, None], fu[None, :used]) - frequency
    band = np.abs(offset) <= NOISE_BAND * sigma
    band[0, 0] = False
    gain = np.exp(-0.5 * (offset[band] / sigma) ** 2).astype(np.float32)
    return np.flatnonzero(band), gain, used


def assert_annulus_is_the_reference(h: int, w: int, frequency: float, du: float,
                                    dv: float) -> None:
    from scenes.textures import _annulus

    index, gain, used = _annulus.__wrapped__(h, w, frequency, du, dv)
    want_index, want_gain, want_used = reference_annulus(h, w, frequency, du, dv)
    assert used == want_used
    np.testing.assert_array_equal(index, want_index)
    assert gain.dtype == np.float32 and gain.tobytes() == want_gain.tobytes()


@pytest.mark.parametrize(("h", "w", "frequency", "du", "dv"), [
    (576, 768, 7.5, 15.07 / 768, 11.2 / 576),  # the flying wall: 40,000 band cells
    (160, 243, 100.5, 0.36 / 243, 0.23 / 160),
    (45, 81, 6.0, 1 / 32, 1 / 40),  # odd sides
    (90, 64, 6.0, 1 / 32, 1 / 40),  # even: the Nyquist row is in the band
    (1, 5, 2.0, 0.1, 0.1),  # one row
    (2, 2, 0.5, 0.9, 0.2),  # the band beyond Nyquist
    (89, 8, 39.3, 0.065, 0.105),  # no band cell below Nyquist
])
def test_annulus_cells_and_gains_are_the_whole_grid_test(h: int, w: int, frequency: float,
                                                          du: float, dv: float) -> None:
    assert_annulus_is_the_reference(h, w, frequency, du, dv)


@pytest.mark.parametrize(("shape", "frequency", "pixel_size"), [
    ((576, 768), 30.0, (1 / 200, 1 / 200)),  # a large flying texture: half the columns used
    ((45, 81), 6.0, (1 / 32, 1 / 40)),  # odd sides
    ((89, 8), 39.3, (0.065, 0.105)),  # no band cell below Nyquist: signed zeros
    ((1, 5), 2.0, (0.1, 0.1)),  # one row
    ((7, 3), 0.5, (0.9, 0.2)),  # the band's outer edge beyond Nyquist on both axes
])
def test_band_limited_noise_bits_equal_the_reference(shape, frequency: float,
                                                     pixel_size) -> None:
    got = band_limited_noise(shape, frequency=frequency, pixel_size=pixel_size,
                             rng=np.random.default_rng(5))
    want = reference_noise(shape, frequency, pixel_size, np.random.default_rng(5))
    assert got.dtype == want.dtype == np.float32 and got.shape == want.shape
    assert got.tobytes() == want.tobytes()


def reference_texture(spec: TextureSpec, *, extent: tuple[float, float]) -> np.ndarray:
    """``make_texture`` written as its docstring's formulas, one temporary per step.

    ``make_texture`` evaluates the same expressions in place and draws random coefficients only
    inside the noise band (to save time and memory); the bytes must not change.
    """
    h, w = texture_shape(spec, extent=extent)
    du, dv = extent[0] / w, extent[1] / h
    rng = np.random.default_rng(spec.seed)
    f32 = np.float32
    if spec.kind == "constant" or spec.contrast == 0.0:
        pattern = np.zeros((h, w), dtype=f32)
    elif spec.kind == "noise":
        noise = reference_noise((h, w), spec.frequency, (du, dv), rng)
        pattern = np.clip(noise * f32(1 / 2.5), -1.0, 1.0)
    else:
        u, v = (np.arange(w) + 0.5) * du, (np.arange(h) + 0.5) * dv
        theta = np.radians(spec.angle)
        along = np.cos(theta) * u[None, :] + np.sin(theta) * v[:, None]
        across = -np.sin(theta) * u[None, :] + np.cos(theta) * v[:, None]
        phase_a, phase_b = rng.uniform(0.0, 2 * np.pi, size=2)
        gain = f32(max(1.0, 1.0 / (spec.frequency * max(du, dv)) / np.pi))

        def square(phase: np.ndarray) -> np.ndarray:  # phase in float64, the rest in float32
            return np.clip(gain * np.sin(phase.astype(f32)), -1.0, 1.0)

        pattern = square(2 * np.pi * spec.frequency * along + phase_a)
        if spec.kind == "checker":
            pattern = pattern * square(2 * np.pi * spec.frequency * across + phase_b)
    grey = np.clip(f32(spec.mean) + f32(spec.contrast * 0.5) * pattern, 0.0, 1.0)
    assert grey.dtype == f32
    return np.stack([np.rint(grey * f32(255.0 * t)) for t in spec.color], -1).astype(np.uint8)


@pytest.mark.parametrize("spec", [
    TextureSpec(kind="noise", frequency=37.5, contrast=0.8, mean=0.5, seed=11),
    TextureSpec(kind="noise", frequency=9.0, contrast=1.0, mean=0.3, color=(0.9, 0.9, 0.6),
                seed=2),
    TextureSpec(kind="checker", frequency=7.0, contrast=0.7, mean=0.55, angle=33.0, seed=4,
                color=(0.8, 0.7, 0.9)),
    TextureSpec(kind="stripes", frequency=5.0, contrast=1.0, mean=0.5, angle=100.0, seed=9),
    TextureSpec(kind="constant", mean=0.42, color=(0.3, 1.0, 0.3)),
])
def test_make_texture_bytes_equal_the_reference_formulas(spec: TextureSpec) -> None:
    extent = (1.7, 1.1)  # e.g. 432 x 256 at 37.5 cycles/m (noise), 95 x 62 checker at 7
    np.testing.assert_array_equal(make_texture(spec, extent=extent),
                                  reference_texture(spec, extent=extent))


@pytest.mark.parametrize("spec", [
    TextureSpec(kind="noise", frequency=9.0, color=(0.9, 0.9, 0.6), seed=2),
    TextureSpec(kind="checker", frequency=7.0, angle=33.0, color=(0.8, 0.7, 0.9)),
    TextureSpec(kind="stripes", frequency=5.0, color=(0.0, 1.0, 0.5)),
    TextureSpec(kind="constant", mean=0.42),
    TextureSpec(kind="image", frequency=20.0, image="skimage:astronaut"),
])
def test_texture_image_holds_make_texture_pixels(spec: TextureSpec) -> None:
    extent = (0.9, 0.6)
    want = make_texture(spec, extent=extent)
    image = texture_image(spec, extent=extent)
    assert image.mode == "RGB" and image.size == (want.shape[1], want.shape[0])
    assert image.tobytes() == want.tobytes()


def test_texture_side_examples() -> None:
    from scenes.textures import _side

    noise = [_side(n, 2048, smooth=True) for n in (1, 7, 11, 97, 1000, 1001, 2048)]
    assert noise == [3, 9, 12, 100, 1000, 1080, 2025]  # 5-smooth, powers of two skipped
    assert [_side(n, 2048, smooth=False) for n in (2, 5, 128, 2048, 3000)] == [3, 5, 129, 2047,
                                                                             2047]
