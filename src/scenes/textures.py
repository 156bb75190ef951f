"""Procedural textures: images covering a surface patch of known size in metres.

A texture image covers a patch of ``extent = (width, height)`` metres: columns run along the
surface coordinate ``u`` (width), rows along ``v`` (height), row 0 at ``v = 0``. Pixel ``(i, j)``
samples the surface at ``u = (j + 0.5) * width / W``, ``v = (i + 0.5) * height / H``, so a
frequency in cycles per metre on the surface is a frequency in cycles per metre of the image,
whatever its pixel count. Images depend on the :class:`~scenes.spec.TextureSpec` (including its
``seed``) and the extent only.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from scenes.spec import TextureSpec

__all__ = ["make_texture", "texture_shape", "band_limited_noise", "PIXELS_PER_CYCLE",
           "MAX_TEXTURE_SIDE"]

#: Default sampling: texture pixels per period of the centre frequency. The noise band reaches
#: about 1.7 x the centre frequency, which keeps >= 4.7 pixels per cycle.
PIXELS_PER_CYCLE = 8.0
#: Largest texture side in pixels (sampling is reduced to stay under it).
MAX_TEXTURE_SIDE = 2048
_CONSTANT_SIDE = 8
_NOISE_RELATIVE_SIGMA = 1.0 / 3.0  # Gaussian annulus width / centre frequency
_NOISE_CLIP_SIGMAS = 2.5  # noise is scaled so +-2.5 standard deviations span [-1, 1]


def texture_shape(spec: TextureSpec, *, extent: tuple[float, float],
                  pixels_per_metre: float | None = None,
                  max_side: int = MAX_TEXTURE_SIDE) -> tuple[int, int]:
    """Image shape ``(H, W)`` that :func:`make_texture` produces for these arguments.

    With ``pixels_per_metre=None`` the sampling is ``PIXELS_PER_CYCLE * spec.frequency``
    (``"constant"``: ``_CONSTANT_SIDE`` pixels along the longer side), reduced where needed so
    that no side exceeds ``max_side``. Each side has at least 2 pixels.

    Examples
    --------
    >>> texture_shape(TextureSpec(frequency=10.0), extent=(2.0, 1.0))
    (80, 160)
    """
    width, height = _check_extent(extent)
    if max_side < 2:
        raise ValueError(f"max_side must be >= 2, got {max_side}")
    if pixels_per_metre is None:
        if spec.kind == "constant":
            ppm = _CONSTANT_SIDE / max(width, height)
        else:
            ppm = PIXELS_PER_CYCLE * spec.frequency
    else:
        ppm = float(pixels_per_metre)
        if not (math.isfinite(ppm) and ppm > 0):
            raise ValueError(f"pixels_per_metre must be finite and > 0, got {pixels_per_metre!r}")
    ppm = min(ppm, max_side / max(width, height))
    return (max(2, min(max_side, round(height * ppm))), max(2, min(max_side, round(width * ppm))))


def _check_extent(extent: tuple[float, float]) -> tuple[float, float]:
    try:
        width, height = (float(e) for e in extent)
    except (TypeError, ValueError):
        raise ValueError(f"extent must be (width, height) in metres, got {extent!r}") from None
    if not all(math.isfinite(e) and e > 0 for e in (width, height)):
        raise ValueError(f"extent must be two finite sizes > 0 in metres, got {extent!r}")
    return width, height


def band_limited_noise(shape: tuple[int, int], *, frequency: float,
                       pixel_size: tuple[float, float], rng: np.random.Generator) -> np.ndarray:
    """Zero-mean, unit-variance isotropic noise with its power around ``frequency``.

    White Gaussian noise filtered in the Fourier domain by the Gaussian annulus
    ``exp(-(|f| - frequency)**2 / (2 sigma**2))``, ``sigma = frequency / 3``. The result is
    periodic over the image (it tiles seamlessly).

    Parameters
    ----------
    shape : (H, W) tuple of int
        Output shape.
    frequency : float
        Centre frequency in cycles per unit of ``pixel_size``.
    pixel_size : (du, dv) tuple of float
        Pixel spacing along columns and rows.
    rng : numpy.random.Generator
        Source of the white noise.

    Returns
    -------
    noise : (H, W) float64 array

    Examples
    --------
    >>> n = band_limited_noise((64, 64), frequency=8.0, pixel_size=(1 / 64, 1 / 64),
    ...                        rng=np.random.default_rng(0))
    >>> n.shape, abs(float(n.mean())) < 1e-9, round(float(n.std()), 6)
    ((64, 64), True, 1.0)
    """
    h, w = shape
    white = rng.standard_normal((h, w))
    spectrum = np.fft.rfft2(white)
    del white
    spectrum *= _annulus_gain(h, w, float(frequency), float(pixel_size[0]), float(pixel_size[1]))
    noise = np.fft.irfft2(spectrum, s=(h, w))
    del spectrum
    # In place, with the arithmetic of ``(noise - noise.mean()) / noise.std()``: same bits.
    mean = noise.mean()
    noise -= mean
    std = math.sqrt(np.add.reduce(np.square(noise), axis=None) / noise.size)
    if std == 0:  # band entirely beyond the grid's Nyquist frequency
        return noise
    noise /= std
    return noise


@functools.lru_cache(maxsize=16)
def _annulus_gain(h: int, w: int, frequency: float, du: float, dv: float) -> np.ndarray:
    """Read-only (h, w // 2 + 1) Gaussian annulus of :func:`band_limited_noise` (zero at DC).

    Cached: scenes rebuilt with new seeds reuse their textures' shapes and frequencies.
    """
    fu = np.fft.rfftfreq(w, d=du)
    fv = np.fft.fftfreq(h, d=dv)
    radius = np.hypot(fv[:, None], fu[None, :])
    sigma = _NOISE_RELATIVE_SIGMA * frequency
    gain = np.exp(-0.5 * ((radius - frequency) / sigma) ** 2)
    gain[0, 0] = 0.0  # zero mean
    gain.setflags(write=False)
    return gain


def _soft_square(phase: np.ndarray, pixels_per_cycle: float) -> np.ndarray:
    """Square wave of ``sin(phase)`` with ~1-pixel antialiased edges, values in [-1, 1].

    Overwrites and returns ``phase``.
    """
    gain = max(1.0, pixels_per_cycle / math.pi)
    np.sin(phase, out=phase)
    phase *= gain
    return np.clip(phase, -1.0, 1.0, out=phase)


def _wave_phase(along: np.ndarray, frequency: float, offset: float) -> np.ndarray:
    """``2 pi frequency along + offset`` (a new array), evaluated as written."""
    phase = np.multiply(along, 2 * math.pi * frequency)
    phase += offset
    return phase


def make_texture(spec: TextureSpec, *, extent: tuple[float, float],
                 pixels_per_metre: float | None = None,
                 max_side: int = MAX_TEXTURE_SIDE) -> np.ndarray:
    """Render a procedural texture covering ``extent`` metres of surface.

    The pattern ``p`` in [-1, 1] becomes the grey level ``g = clip(mean + contrast * 0.5 * p,
    0, 1)``, tinted: ``rgb = g * color``, stored as ``round(255 * rgb)``.

    - ``"noise"``: :func:`band_limited_noise` at ``spec.frequency`` cycles per metre, scaled by
      1 / 2.5 standard deviations and clipped to [-1, 1].
    - ``"checker"``: ``frequency`` cycles per metre along both pattern axes (one period = two
      squares), rotated by ``angle`` degrees; edges antialiased over about one pixel.
    - ``"stripes"``: square wave of ``frequency`` cycles per metre along the direction at
      ``angle`` degrees from ``u`` toward ``v`` (``angle=0``: vertical stripes).
    - ``"constant"``: ``p = 0``.

    The random phase (checker, stripes) and the noise come from
    ``np.random.default_rng(spec.seed)`` only.

    Parameters
    ----------
    spec : TextureSpec
        What to draw.
    extent : (width, height) tuple of float
        Size in metres of the surface patch the image covers (``u`` along width).
    pixels_per_metre : float, optional
        Sampling; default ``PIXELS_PER_CYCLE * spec.frequency`` (see :func:`texture_shape`).
    max_side : int
        Cap on either image side; sampling is reduced to fit. Beyond the resulting Nyquist
        frequency, noise loses its high band and checker/stripes alias.

    Returns
    -------
    image : (H, W, 3) uint8 array

    Examples
    --------
    >>> img = make_texture(TextureSpec(kind="checker", frequency=2.0, contrast=1.0),
    ...                    extent=(1.0, 0.5))
    >>> img.shape, img.dtype.name
    ((8, 16, 3), 'uint8')
    >>> make_texture(TextureSpec(contrast=0.0, mean=0.5), extent=(1.0, 1.0))[0, 0].tolist()
    [128, 128, 128]
    """
    if not isinstance(spec, TextureSpec):
        raise TypeError(f"spec must be a TextureSpec, got {type(spec).__name__}")
    width, height = _check_extent(extent)
    h, w = texture_shape(spec, extent=extent, pixels_per_metre=pixels_per_metre,
                         max_side=max_side)
    du, dv = width / w, height / h
    rng = np.random.default_rng(spec.seed)
    # Array expressions below are evaluated in place, in the order the formulas read, so
    # the bytes do not depend on the temporaries saved.
    if spec.kind == "constant" or spec.contrast == 0.0:
        pattern = np.zeros((h, w))
    elif spec.kind == "noise":
        pattern = band_limited_noise((h, w), frequency=spec.frequency, pixel_size=(du, dv),
                                     rng=rng)
        pattern /= _NOISE_CLIP_SIGMAS
        np.clip(pattern, -1.0, 1.0, out=pattern)
    else:
        u = (np.arange(w) + 0.5) * du
        v = (np.arange(h) + 0.5) * dv
        theta = math.radians(spec.angle)
        along = math.cos(theta) * u[None, :] + math.sin(theta) * v[:, None]
        phase_a, phase_b = rng.uniform(0.0, 2 * math.pi, size=2)
        px_per_cycle = 1.0 / (spec.frequency * max(du, dv))
        pattern = _soft_square(_wave_phase(along, spec.frequency, phase_a), px_per_cycle)
        if spec.kind == "checker":
            across = -math.sin(theta) * u[None, :] + math.cos(theta) * v[:, None]
            pattern *= _soft_square(_wave_phase(across, spec.frequency, phase_b), px_per_cycle)
    # grey = clip(mean + contrast * 0.5 * pattern, 0, 1)
    grey = pattern
    grey *= spec.contrast * 0.5
    grey += spec.mean
    np.clip(grey, 0.0, 1.0, out=grey)
    out = np.empty((h, w, 3), dtype=np.uint8)
    level = np.empty_like(grey)
    done: dict[float, int] = {}
    for channel, tint in enumerate(spec.color):
        if tint in done:  # same tint as an earlier channel: same bytes
            out[:, :, channel] = out[:, :, done[tint]]
            continue
        np.multiply(grey, 255.0 * tint, out=level)
        np.rint(level, out=level)
        out[:, :, channel] = level
        done[tint] = channel
    return out
