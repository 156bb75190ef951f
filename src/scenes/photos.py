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

__all__ = ["photo_frequency", "photo_source", "photo_pixels_per_metre", "photo_texture"]

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


def _mirror(index: np.ndarray, n: int) -> np.ndarray:
    m = np.mod(index, 2 * n)
    return np.where(m >= n, 2 * n - 1 - m, m)


def photo_texture(spec: TextureSpec, shape: tuple[int, int], extent: tuple[float, float]
                  ) -> np.ndarray:
    """The (H, W, 3) uint8 texture of an ``"image"`` spec covering ``extent`` metres."""
    h, w = shape
    width, height = extent
    source = photo_source(spec)
    photo = load_photo(source)
    ppm = spec.frequency / photo_frequency(source)  # photo pixels per metre
    texel_ppm = min(w / width, h / height)
    if texel_ppm < ppm:  # fewer texels than photo pixels per metre: reduce first (box filter)
        from PIL import Image

        factor = texel_ppm / ppm
        ph, pw = photo.shape[:2]
        size = (max(2, round(pw * factor)), max(2, round(ph * factor)))
        photo = np.asarray(Image.fromarray(photo).resize(size, Image.Resampling.BOX))
        ppm *= size[0] / pw
    data = photo.astype(np.float32) / np.float32(255.0)
    grey = load_photo(source).astype(np.float64) @ _BT601 / 255.0
    mu, sigma = float(grey.mean()), float(grey.std())
    rng = np.random.default_rng(spec.seed)
    ph, pw = data.shape[:2]
    off_x, off_y = rng.uniform(size=2) * (pw, ph)
    u = (np.arange(w) + 0.5) * (width / w)
    v = (np.arange(h) + 0.5) * (height / h)
    theta = math.radians(spec.angle)
    c, s = math.cos(theta), math.sin(theta)
    x = (c * u[None, :] - s * v[:, None]) * ppm + off_x - 0.5
    y = (s * u[None, :] + c * v[:, None]) * ppm + off_y - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    tx, ty = (x - x0).astype(np.float32)[..., None], (y - y0).astype(np.float32)[..., None]
    xa, xb = _mirror(x0.astype(np.int64), pw), _mirror(x0.astype(np.int64) + 1, pw)
    ya, yb = _mirror(y0.astype(np.int64), ph), _mirror(y0.astype(np.int64) + 1, ph)
    top = data[ya, xa] * (1 - tx) + data[ya, xb] * tx
    bottom = data[yb, xa] * (1 - tx) + data[yb, xb] * tx
    rgb = top * (1 - ty) + bottom * ty
    if sigma > 0 and spec.contrast > 0:
        pattern = np.clip((rgb - np.float32(mu)) / np.float32(_CLIP_SIGMAS * sigma), -1.0, 1.0)
        rgb = np.float32(spec.mean) + np.float32(0.5 * spec.contrast) * pattern
    else:
        rgb = np.full_like(rgb, np.float32(spec.mean))
    rgb = np.clip(rgb, 0.0, 1.0) * np.asarray(spec.color, dtype=np.float32) * np.float32(255.0)
    return np.rint(rgb).astype(np.uint8)
