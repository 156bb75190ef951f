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
from PIL import Image

from scenes.photos import photo_pixels_per_metre, photo_planes, photo_texture
from scenes.spec import TextureSpec

__all__ = ["make_texture", "texture_image", "texture_shape", "band_limited_noise",
           "PIXELS_PER_CYCLE", "NOISE_PIXELS_PER_CYCLE", "NOISE_BAND", "MAX_TEXTURE_SIDE"]

#: Default sampling of checker and stripes: texture pixels per period (edges are antialiased
#: over about one pixel, so this sets their sharpness).
PIXELS_PER_CYCLE = 8.0
#: The noise spectrum is the Gaussian annulus ``exp(-(|f| - f0)**2 / (2 sigma**2))``,
#: ``sigma = f0 / 3``, cut to ``|f| - f0 <= NOISE_BAND * sigma`` (the cut drops ~0.5 % of the
#: power): nothing above ``(1 + NOISE_BAND / 3) * f0 = 5/3 f0`` is present.
NOISE_BAND = 2.0
#: Default sampling of noise: 4 pixels per period of its highest frequency (5/3 of the centre
#: frequency), i.e. 20/3 pixels per period of the centre frequency. Mipmapping filters the rest.
NOISE_PIXELS_PER_CYCLE = 4.0 * (1.0 + NOISE_BAND / 3.0)
#: Largest texture side in pixels (sampling is reduced to stay under it).
MAX_TEXTURE_SIDE = 2048
_CONSTANT_SIDE = 6
_NOISE_RELATIVE_SIGMA = 1.0 / 3.0  # Gaussian annulus width / centre frequency
_NOISE_CLIP_SIGMAS = 2.5  # noise is scaled so +-2.5 standard deviations span [-1, 1]


def texture_shape(spec: TextureSpec, *, extent: tuple[float, float],
                  pixels_per_metre: float | None = None,
                  max_side: int = MAX_TEXTURE_SIDE) -> tuple[int, int]:
    """Image shape ``(H, W)`` that :func:`make_texture` produces for these arguments.

    With ``pixels_per_metre=None`` the sampling is ``NOISE_PIXELS_PER_CYCLE * spec.frequency``
    for noise, ``PIXELS_PER_CYCLE * spec.frequency`` for checker and stripes, one texel per
    photo pixel for ``"image"`` (:func:`scenes.photos.photo_pixels_per_metre`; ``"constant"``:
    ``_CONSTANT_SIDE`` pixels along the longer side), reduced where needed so that no side
    exceeds ``max_side``. Each side is then adjusted, within ``[3, max_side]``: never a power of
    two (llvmpipe, the CPU rasteriser, compiles separate shader variants for power-of-two
    textures, at ~75 ms each per process), and for noise the next length up whose only prime
    factors are 2, 3 and 5 (fast FFTs).

    Examples
    --------
    >>> texture_shape(TextureSpec(kind="checker", frequency=10.0), extent=(2.0, 1.0))
    (80, 160)
    >>> texture_shape(TextureSpec(kind="noise", frequency=10.0), extent=(2.0, 1.0))
    (72, 135)
    >>> texture_shape(TextureSpec(kind="stripes", frequency=8.0), extent=(2.0, 1.0))
    (65, 129)
    """
    width, height = _check_extent(extent)
    if max_side < 3:
        raise ValueError(f"max_side must be >= 3 (the smallest texture side), got {max_side}")
    if pixels_per_metre is None:
        if spec.kind == "constant":
            ppm = _CONSTANT_SIDE / max(width, height)
        elif spec.kind == "noise":
            ppm = NOISE_PIXELS_PER_CYCLE * spec.frequency
        elif spec.kind == "image":
            ppm = photo_pixels_per_metre(spec)
        else:
            ppm = PIXELS_PER_CYCLE * spec.frequency
    else:
        ppm = float(pixels_per_metre)
        if not (math.isfinite(ppm) and ppm > 0):
            raise ValueError(f"pixels_per_metre must be finite and > 0, got {pixels_per_metre!r}")
    ppm = min(ppm, max_side / max(width, height))
    smooth = spec.kind == "noise"
    return (_side(round(height * ppm), max_side, smooth=smooth),
            _side(round(width * ppm), max_side, smooth=smooth))


def _side(n: int, max_side: int, *, smooth: bool) -> int:
    """Texture side near ``n`` (at least 3, at most ``max_side``) that is not a power of two
    and, with ``smooth``, is 5-smooth: the next such length up, else the largest one below."""
    n = max(3, min(n, max_side))
    if smooth:
        lengths = _FAST_LENGTHS
        k = int(np.searchsorted(lengths, n))
        if k < lengths.size and lengths[k] <= max_side:
            return int(lengths[k])
        k = int(np.searchsorted(lengths, max_side, side="right")) - 1
        return int(lengths[k]) if k >= 0 else n
    if n & (n - 1) == 0:  # a power of two
        return n + 1 if n + 1 <= max_side else (n - 1 if n > 3 else n)
    return n


def _fast_lengths(limit: int) -> np.ndarray:
    """Sorted integers in [3, limit] of the form ``2**a * 3**b * 5**c``, powers of two excluded."""
    out = []
    p5 = 1
    while p5 <= limit:
        p35 = p5
        while p35 <= limit:
            m = p35
            while m <= limit:
                out.append(m)
                m *= 2
            p35 *= 3
        p5 *= 5
    lengths = np.array(sorted(n for n in out if n >= 3 and n & (n - 1)), dtype=np.int64)
    lengths.setflags(write=False)
    return lengths


_FAST_LENGTHS = _fast_lengths(1 << 20)


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

    Gaussian noise whose spectrum is the Gaussian annulus
    ``exp(-(|f| - frequency)**2 / (2 sigma**2))``, ``sigma = frequency / 3``, cut to
    ``||f| - frequency| <= NOISE_BAND * sigma`` (and zero at DC). It is synthesised in the
    Fourier domain: independent complex Gaussian coefficients (drawn from ``rng``, in float32,
    only inside the band) times the annulus, then one inverse real FFT in float32. This is
    white noise filtered by the annulus, in distribution. The result is periodic over the
    image (it tiles seamlessly).

    Parameters
    ----------
    shape : (H, W) tuple of int
        Output shape.
    frequency : float
        Centre frequency in cycles per unit of ``pixel_size``.
    pixel_size : (du, dv) tuple of float
        Pixel spacing along columns and rows.
    rng : numpy.random.Generator
        Source of the random coefficients.

    Returns
    -------
    noise : (H, W) float32 array
        All zeros if the band lies entirely beyond the grid's Nyquist frequency.

    Examples
    --------
    >>> n = band_limited_noise((64, 64), frequency=8.0, pixel_size=(1 / 64, 1 / 64),
    ...                        rng=np.random.default_rng(0))
    >>> n.shape, n.dtype.name, abs(float(n.mean())) < 1e-6, round(float(n.std()), 4)
    ((64, 64), 'float32', True, 1.0)
    """
    h, w = (int(n) for n in shape)
    index, gain, used = _annulus(h, w, float(frequency), float(pixel_size[0]),
                                 float(pixel_size[1]))
    coefficients = rng.standard_normal((2, index.size), dtype=np.float32)
    coefficients *= gain
    # np.fft.irfft2(spectrum, s=(h, w)) is an ifft down each column, then an irfft along each
    # row. Only the first ``used`` columns hold band cells: the column transforms run on those
    # alone (the others stay zero), the same bits in ~20 % less FFT time.
    spectrum = np.zeros((h, w // 2 + 1), dtype=np.complex64)
    if index.size:
        band = np.zeros((h, used), dtype=np.complex64)
        flat = band.reshape(-1)
        flat.real[index] = coefficients[0]
        flat.imag[index] = coefficients[1]
        np.fft.ifft(band, axis=0, out=spectrum[:, :used])
        del band
        noise = np.fft.irfft(spectrum, n=w, axis=1)
    else:  # no band cell below Nyquist: zeros, signed as irfft2 signs them
        noise = np.fft.irfft2(spectrum, s=(h, w))
    del spectrum
    noise -= noise.mean(dtype=np.float64)
    std = math.sqrt(float(np.square(noise).mean(dtype=np.float64)))
    if std > 0:
        noise *= np.float32(1.0 / std)
    return noise


@functools.lru_cache(maxsize=32)
def _annulus(h: int, w: int, frequency: float, du: float, dv: float
             ) -> tuple[np.ndarray, np.ndarray, int]:
    """Where the cut annulus of :func:`band_limited_noise` is non-zero on the (h, w // 2 + 1)
    rfft grid: the number ``used`` of leading columns that can hold band cells, the flat
    indices of the band cells into the grid's (h, used) left part, and the float32 gain there
    (read-only arrays).

    A cell is in the band where ``|hypot(fv, fu) - frequency| <= NOISE_BAND * sigma``, evaluated
    as written for every cell of a window per row: the columns between the band's inner and
    outer radius at that row, widened by a column on each side and by 1e-6 of the radii (the
    cells outside it are far from the band's edge, beyond any rounding), so the band cells and
    their float values are those of the test over the whole grid, with a fraction of the
    ``hypot`` calls (the rows of a flying texture's band hold ~3/4 of its bounding box).

    Cached: scenes rebuilt with new seeds reuse their textures' shapes and frequencies.
    """
    fu = np.fft.rfftfreq(w, d=du)  # column j: j * (1 / (w du)), ascending from 0
    fv = np.fft.fftfreq(h, d=dv)
    sigma = _NOISE_RELATIVE_SIGMA * frequency
    half = NOISE_BAND * sigma
    reach = (frequency + half) * (1 + 1e-6)
    rows = np.flatnonzero(np.abs(fv) <= reach)
    used = int(np.count_nonzero(fu <= reach))
    fr = fv[rows]
    spacing = 1.0 / (w * du)
    inner = max(frequency - half, 0.0) * (1 - 1e-6)
    hi = np.sqrt(np.maximum(reach * reach - fr * fr, 0.0)) / spacing
    lo = np.sqrt(np.maximum(inner * inner - fr * fr, 0.0)) / spacing
    first = np.maximum(np.floor(lo).astype(np.int64) - 1, 0)
    count = np.maximum(np.minimum(np.ceil(hi).astype(np.int64) + 1, used - 1) - first + 1, 0)
    # the windows' cells in row-major order, as np.nonzero of the whole grid gives them
    row = np.repeat(np.arange(rows.size), count)
    col = np.arange(row.size) + np.repeat(first - (np.cumsum(count) - count), count)
    offset = np.hypot(fr[row], fu[col]) - frequency
    inside = np.abs(offset) <= half
    index = rows[row[inside]] * used + col[inside]
    offset = offset[inside]
    keep = index != 0  # zero mean
    index, offset = index[keep], offset[keep]
    gain = np.exp(-0.5 * (offset / sigma) ** 2).astype(np.float32)
    index.setflags(write=False)
    gain.setflags(write=False)
    return index, gain, used


def _soft_square(phase: np.ndarray, pixels_per_cycle: float) -> np.ndarray:
    """Square wave of ``sin(phase)`` with ~1-pixel antialiased edges, values in [-1, 1].

    Overwrites and returns ``phase``.
    """
    gain = max(1.0, pixels_per_cycle / math.pi)
    np.sin(phase, out=phase)
    phase *= np.float32(gain)
    return np.clip(phase, -1.0, 1.0, out=phase)


def _wave_phase(along: np.ndarray, frequency: float, offset: float) -> np.ndarray:
    """``2 pi frequency along + offset`` evaluated in float64, returned as a new float32 array."""
    phase = np.multiply(along, 2 * math.pi * frequency)
    phase += offset
    return phase.astype(np.float32)


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
    - ``"image"``: a photograph, :func:`scenes.photos.photo_texture` (same ``mean``, ``contrast``
      and ``color`` rule, ``p`` from the photograph's normalised grey levels per channel).

    Patterns and grey levels are computed in float32 (checker and stripe phases in float64). The random phase (checker, stripes)
    and the noise come from ``np.random.default_rng(spec.seed)`` only: the same arguments give
    the same bytes.

    Parameters
    ----------
    spec : TextureSpec
        What to draw.
    extent : (width, height) tuple of float
        Size in metres of the surface patch the image covers (``u`` along width).
    pixels_per_metre : float, optional
        Sampling; default ``NOISE_PIXELS_PER_CYCLE * spec.frequency`` for noise,
        ``PIXELS_PER_CYCLE * spec.frequency`` otherwise (see :func:`texture_shape`).
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
    ((9, 17, 3), 'uint8')
    >>> make_texture(TextureSpec(contrast=0.0, mean=0.5), extent=(1.0, 1.0))[0, 0].tolist()
    [128, 128, 128]
    """
    h, w = _checked_shape(spec, extent, pixels_per_metre, max_side)
    if spec.kind == "image":
        return photo_texture(spec, (h, w), _check_extent(extent))
    # contiguous planes interleaved in one pass (5x faster than strided channel writes)
    return np.dstack(_planes(spec, (h, w), extent))


def texture_image(spec: TextureSpec, *, extent: tuple[float, float],
                  pixels_per_metre: float | None = None,
                  max_side: int = MAX_TEXTURE_SIDE) -> Image.Image:
    """:func:`make_texture`'s image as an RGB ``PIL.Image`` (what a mesh material holds).

    The same pixels; the channel planes are merged straight into the image, without the
    interleaved array (half the copying). PIL stores RGB pixels in four bytes; the fourth (not
    part of the image, ``tobytes("raw", "RGBX")`` shows it) is 0 here, 255 after
    ``Image.fromarray``.

    Examples
    --------
    >>> spec = TextureSpec(kind="stripes", frequency=8.0, color=(1.0, 0.5, 0.25))
    >>> image = texture_image(spec, extent=(2.0, 1.0))
    >>> image.mode, image.size
    ('RGB', (129, 65))
    >>> bool(np.array_equal(np.asarray(image), make_texture(spec, extent=(2.0, 1.0))))
    True
    """
    h, w = _checked_shape(spec, extent, pixels_per_metre, max_side)
    if spec.kind == "image":
        planes = photo_planes(spec, (h, w), _check_extent(extent))
    else:
        planes = _planes(spec, (h, w), extent)
    return Image.merge("RGB", [Image.frombuffer("L", (w, h), plane, "raw", "L", 0, 1)
                               for plane in planes])


def _checked_shape(spec: TextureSpec, extent: tuple[float, float],
                   pixels_per_metre: float | None, max_side: int) -> tuple[int, int]:
    if not isinstance(spec, TextureSpec):
        raise TypeError(f"spec must be a TextureSpec, got {type(spec).__name__}")
    return texture_shape(spec, extent=extent, pixels_per_metre=pixels_per_metre,
                         max_side=max_side)


def _planes(spec: TextureSpec, shape: tuple[int, int], extent: tuple[float, float]
            ) -> list[np.ndarray]:
    """The red, green and blue (h, w) uint8 planes of a pattern texture (not ``"image"``),
    C-contiguous; channels of the same tint share one array."""
    h, w = shape
    width, height = _check_extent(extent)
    du, dv = width / w, height / h
    rng = np.random.default_rng(spec.seed)
    if spec.kind == "constant" or spec.contrast == 0.0:
        grey = np.full((h, w), np.float32(spec.mean))
    else:
        if spec.kind == "noise":
            pattern = band_limited_noise((h, w), frequency=spec.frequency, pixel_size=(du, dv),
                                         rng=rng)
            pattern *= np.float32(1.0 / _NOISE_CLIP_SIGMAS)
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
                pattern *= _soft_square(_wave_phase(across, spec.frequency, phase_b),
                                        px_per_cycle)
        # grey = clip(mean + contrast * 0.5 * clip(pattern, -1, 1), 0, 1)
        np.clip(pattern, -1.0, 1.0, out=pattern)
        grey = pattern
        grey *= np.float32(spec.contrast * 0.5)
        grey += np.float32(spec.mean)
        np.clip(grey, 0.0, 1.0, out=grey)
    planes: dict[float, np.ndarray] = {}  # one uint8 plane per distinct tint
    level = np.empty_like(grey)
    for tint in spec.color:
        if tint not in planes:
            np.multiply(grey, np.float32(255.0 * tint), out=level)
            np.rint(level, out=level)
            planes[tint] = level.astype(np.uint8)
    return [planes[tint] for tint in spec.color]
