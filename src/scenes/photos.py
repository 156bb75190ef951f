"""Photograph textures: a real image mapped onto a surface at a known spatial frequency.

**What "cycles" means for a photograph.** A photograph has no single frequency; we use its
*mean spatial frequency* ``f_photo`` in cycles per photo pixel, measured once per photograph
(:func:`photo_frequency`, cached): the power-weighted mean of ``|f|`` over the 2-D power spectrum
of its BT.601 grey image, mean removed and multiplied by a separable Hann window (so the image's
borders add no spurious high frequencies). A texture of kind ``"image"`` and ``frequency = F``
cycles per metre places ``F / f_photo`` photo pixels on each metre of surface, so the photograph's
mean frequency lands on ``F``; in a dataset ``frequency_px`` then means the same thing as for the
procedural kinds (cycles per image pixel at the object's reference depth). ``docs/datasets.md``
lists ``f_photo`` of every built-in photograph.

**Mapping.** Texel ``(i, j)`` at surface point ``(u, v)`` (metres, as in :mod:`scenes.textures`)
samples the photograph bilinearly at ``R(angle) (u, v) * F / f_photo + offset``, the offset drawn
uniformly over the photograph from ``default_rng(seed)``, the photograph repeated by mirror
reflection (seamless) beyond its borders; a folder's file is chosen by the next draw. When the
texture has fewer pixels per metre than the photograph (``max_side``), the photograph is first
reduced with a box filter (Pillow) so that it does not alias.

**Contrast and mean.** With the photograph's grey mean ``mu`` and standard deviation ``sigma``
(over the whole photograph), each channel ``c`` becomes ``p = clip((I_c - mu) / (2.5 sigma), -1,
1)`` and ``clip(mean + contrast * 0.5 * p, 0, 1) * color_c``: the noise kind's scaling, so
``contrast`` and ``mean`` mean the same for both (a colour photograph keeps its hues).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from scenes.assets import list_folder, load_photo
from scenes.spec import TextureSpec

__all__ = ["photo_frequency", "photo_source", "photo_pixels_per_metre", "photo_texture",
           "photo_planes"]

_BT601 = np.array([0.299, 0.587, 0.114])
_CLIP_SIGMAS = 2.5


def photo_source(spec: TextureSpec) -> str:
    """The photograph a texture of kind ``"image"`` uses: its ``image``, or for a folder the file
    chosen by ``spec.seed`` (the second draw of ``default_rng(seed)``, after the offset's)."""
    import os

    if spec.image.startswith("skimage:") or not os.path.isdir(spec.image):
        return spec.image
    files = list_folder(spec.image)
    rng = np.random.default_rng(spec.seed)
    rng.uniform(size=2)  # the offset's draws
    return files[int(rng.integers(len(files)))]


def photo_frequency(source: str) -> float:
    """Mean spatial frequency of a photograph, cycles per photo pixel (see the module docstring).

    Examples
    --------
    >>> 0.01 < photo_frequency("skimage:brick") < 0.5
    True
    """
    return _frequency(source, _grey_stats_key(source))


def _grey_stats_key(source: str) -> tuple[int, ...]:
    photo = load_photo(source)  # cached; its shape and a checksum key the measurement
    return photo.shape + (int(photo[::7, ::7].sum(dtype=np.int64)),)


@functools.lru_cache(maxsize=64)
def _frequency(source: str, key: tuple[int, ...]) -> float:
    grey = load_photo(source).astype(np.float64) @ _BT601
    grey -= grey.mean()
    h, w = grey.shape
    grey *= np.hanning(h)[:, None] * np.hanning(w)[None, :]
    power = np.abs(np.fft.rfft2(grey)) ** 2
    radius = np.hypot(np.fft.fftfreq(h)[:, None], np.fft.rfftfreq(w)[None, :])
    weight = np.ones(power.shape[1])  # the rfft half-plane: inner columns stand for two
    weight[1:(w + 1) // 2] = 2.0
    total = float((power * weight).sum())
    if total <= 0:
        return 0.25  # a constant photograph: any scale looks the same
    return float((power * radius * weight).sum() / total)


def photo_pixels_per_metre(spec: TextureSpec) -> float:
    """Photo pixels per metre of surface of an ``"image"`` texture: ``frequency / f_photo``."""
    return spec.frequency / photo_frequency(photo_source(spec))


@functools.lru_cache(maxsize=64)
def _grey_stats(source: str, key: tuple[int, ...]) -> tuple[float, float]:
    """Mean and standard deviation of the photograph's BT.601 grey levels in [0, 1]."""
    grey = load_photo(source).astype(np.float64) @ _BT601 / 255.0
    return float(grey.mean()), float(grey.std())


def _float_planes(source: str, size: tuple[int, int] | None) -> tuple[np.ndarray, ...]:
    """The photograph's red, green and blue planes as flat float32 arrays of ``value / 255``,
    reduced to ``size`` (width, height) with Pillow's box filter first if given. Not cached: a
    texture's reduction size is its own (5 hits in 47 calls over 8 middlebury-like samples),
    and a large photograph's planes take 12 bytes a pixel."""
    photo = load_photo(source)
    if size is not None:
        from PIL import Image

        photo = np.asarray(Image.fromarray(photo).resize(size, Image.Resampling.BOX))
    planes = []
    for c in range(3):
        plane = photo[..., c].astype(np.float32).reshape(-1)
        plane /= np.float32(255.0)
        planes.append(plane)
    return tuple(planes)


#: Texels per block of rows in :func:`photo_planes`: its ~40 arrays of a block stay in cache.
_BLOCK_TEXELS = 1 << 15


def photo_texture(spec: TextureSpec, shape: tuple[int, int], extent: tuple[float, float]
                  ) -> np.ndarray:
    """The (H, W, 3) uint8 texture of an ``"image"`` spec covering ``extent`` metres."""
    return np.dstack(photo_planes(spec, shape, extent))


def photo_planes(spec: TextureSpec, shape: tuple[int, int], extent: tuple[float, float]
                 ) -> list[np.ndarray]:
    """:func:`photo_texture`'s red, green and blue (H, W) uint8 planes, C-contiguous.

    Texels are computed a block of rows at a time, channel by channel, with the float32 and
    float64 operations of the formula in the module docstring in the same order (the same
    bits as evaluating it over whole (H, W, 3) arrays, ~5x faster: the blocks stay in cache).
    The photograph's grey statistics are cached per photograph.
    """
    h, w = shape
    width, height = extent
    source = photo_source(spec)
    key = _grey_stats_key(source)
    ppm = spec.frequency / _frequency(source, key)  # photo pixels per metre
    texel_ppm = min(w / width, h / height)
    ph, pw = load_photo(source).shape[:2]
    size = None
    if texel_ppm < ppm:  # fewer texels than photo pixels per metre: reduce first (box filter)
        factor = texel_ppm / ppm
        size = (max(2, round(pw * factor)), max(2, round(ph * factor)))
        ppm *= size[0] / pw
        pw, ph = size
    mu, sigma = _grey_stats(source, key)
    rng = np.random.default_rng(spec.seed)
    off_x, off_y = rng.uniform(size=2) * (pw, ph)
    u = (np.arange(w) + 0.5) * (width / w)
    v = (np.arange(h) + 0.5) * (height / h)
    theta = math.radians(spec.angle)
    c, s = math.cos(theta), math.sin(theta)
    # x = (c u - s v) ppm + off_x - 0.5 and y = (s u + c v) ppm + off_y - 0.5, per texel
    cu, su, sv, cv = c * u, s * u, s * v, c * v
    f32 = np.float32
    contrasted = sigma > 0 and spec.contrast > 0
    centre, spread = f32(mu), f32(_CLIP_SIGMAS * sigma)
    level, gain = f32(spec.mean), f32(0.5 * spec.contrast)
    tints = [f32(t) for t in spec.color]
    if not contrasted:  # every texel: clip(mean, 0, 1) * color * 255, rounded
        flat = [np.full((1,), level) for _ in range(3)]
        for ch, a in enumerate(flat):
            np.clip(a, 0.0, 1.0, out=a)
            a *= tints[ch]
            a *= f32(255.0)
            np.rint(a, out=a)
        return [np.full((h, w), a[0], np.uint8) for a in flat]
    data = _float_planes(source, size)
    out = [np.empty((h, w), np.uint8) for _ in range(3)]
    rows = max(1, _BLOCK_TEXELS // w)
    for r0 in range(0, h, rows):
        r1 = min(h, r0 + rows)
        x = np.subtract(cu, sv[r0:r1, None])
        x *= ppm
        x += off_x
        x -= 0.5
        y = np.add(su, cv[r0:r1, None])
        y *= ppm
        y += off_y
        y -= 0.5
        x0, y0 = np.floor(x), np.floor(y)
        tx, ty = (x - x0).astype(np.float32), (y - y0).astype(np.float32)
        xa, xb = _mirror_pair(x0, pw)
        ya, yb = _mirror_pair(y0, ph)
        ya *= pw
        yb *= pw
        corners = [(row + col).astype(np.intp) for row, col in ((ya, xa), (ya, xb), (yb, xa),
                                                                (yb, xb))]
        ox, oy = 1 - tx, 1 - ty
        for ch in range(3):
            a, b, cc, d = (data[ch].take(i) for i in corners)
            a *= ox  # top = a (1 - tx) + b tx, bottom = cc (1 - tx) + d tx
            b *= tx
            a += b
            cc *= ox
            d *= tx
            cc += d
            a *= oy  # value = top (1 - ty) + bottom ty
            cc *= ty
            a += cc
            a -= centre  # mean + contrast / 2 * clip((value - mu) / (2.5 sigma), -1, 1)
            a /= spread
            np.clip(a, -1.0, 1.0, out=a)
            a *= gain
            a += level
            np.clip(a, 0.0, 1.0, out=a)
            a *= tints[ch]
            a *= f32(255.0)
            np.rint(a, out=a)
            out[ch][r0:r1] = a
    return out


def _mirror_pair(start: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The indices ``k`` and ``k + 1`` of the integral float64 array ``start`` reflected into
    ``[0, n)`` (the photograph repeated by mirror reflection), as float64, without a branch.

    With ``m = k mod 2n`` the reflection is ``m`` if ``m < n`` else ``2n - 1 - m``, i.e.
    ``c - |m - c|`` for ``c = n - 1/2``; that of ``k + 1`` is ``max(c - |m + 1 - c|, 0)`` (the
    formula gives -1 at ``m = 2n - 1``, where ``k + 1`` wraps to 0). ``m`` is exact: the
    quotient of two integers below 2**53 is correctly rounded, so its floor is. ~4x faster than
    int64 ``np.mod`` and ``np.where``.
    """
    period = 2.0 * n
    centre = n - 0.5
    m = np.floor(start / period)
    m *= period
    np.subtract(start, m, out=m)
    first = np.subtract(m, centre)
    np.abs(first, out=first)
    np.subtract(centre, first, out=first)
    m -= centre - 1.0
    np.abs(m, out=m)
    np.subtract(centre, m, out=m)
    np.maximum(m, 0.0, out=m)
    return first, m
