"""Texture mip levels made by stereoforge, not by the GL implementation.

``glGenerateMipmap`` leaves the reduction filter to the implementation (OpenGL 4.5, 8.14.4:
"the internal formats of the derived mipmap arrays ... the filter used ... are
implementation-dependent"), so the same texture gets different mip levels from llvmpipe and from
a GPU driver, and a rendered image that samples them differs too (one of the freedoms
``docs/ground-truth.md`` lists). Here every level is computed on the CPU and uploaded, so every
driver samples the same texels. On llvmpipe the CPU cost is about that of its own
``glGenerateMipmap`` (a blit through its rasterizer): less on the AVX-512 machine it was first
measured on, a little more on an AVX2 one (``docs/scale.md``, *Less CPU, second round*).

The filter is llvmpipe's (Mesa 22.3), written down: level ``k + 1`` of a level of ``n`` texels
along an axis has ``m = max(1, n // 2)``; its texel ``i`` is the bilinear sample of level ``k``
at its centre, computed as

- ``s = i * (1 / m) + 0.5 * (1 / m)`` in float32 (the centre in normalised coordinates),
- ``U = rint(float32(s * n) * 256) - 128``: the sample position in 1/256 texel, less half a
  texel; ``i0 = U >> 8`` and the weight ``t = U & 255`` of texel ``i0 + 1`` (clamped to the
  edge),
- per channel, ``lerp(a, b, t) = (a * (256 - t) + b * t + 128) >> 8`` along x on both rows,
  then along y.

For an even ``n`` each texel is the mean of a 2 x 2 block, rounded twice (each row's pair half
up, then the two rows half up). Against the levels llvmpipe
itself makes, it is bit-identical on even levels and on every level of the textures we checked
up to a few hundred texels; on larger odd levels ~0.1-0.6 % of the texels differ by 1 grey level
(llvmpipe's rasterizer interpolates the coordinate with its own float rounding;
``tests/synth/test_mipmaps.py`` measures it).
"""

from __future__ import annotations

import functools

import numpy as np
from numba import njit

__all__ = ["mip_chain", "mip_shapes", "reduce_level"]


def mip_shapes(height: int, width: int) -> list[tuple[int, int]]:
    """``(h, w)`` of every level down to 1 x 1, level 0 first (OpenGL's complete chain).

    Examples
    --------
    >>> mip_shapes(3, 5)
    [(3, 5), (1, 2), (1, 1)]
    """
    shapes = [(int(height), int(width))]
    while shapes[-1] != (1, 1):
        h, w = shapes[-1]
        shapes.append((max(1, h // 2), max(1, w // 2)))
    return shapes


@functools.lru_cache(maxsize=256)
def _taps(n_old: int, n_new: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per output texel along one axis: the two source texels and the 8-bit weight of the
    second (see the module docstring)."""
    f32 = np.float32
    step = f32(1.0) / f32(n_new)
    s = np.arange(n_new, dtype=f32) * step + f32(0.5) * step
    u = (s * f32(n_old)).astype(np.float64) * 256.0  # exact: a float32 times a power of two
    pos = np.rint(u).astype(np.int64) - 128
    first = pos >> 8
    weight = (pos & 255).astype(np.int32)
    taps = (np.clip(first, 0, n_old - 1).astype(np.int32),
            np.clip(first + 1, 0, n_old - 1).astype(np.int32), weight)
    for array in taps:
        array.setflags(write=False)
    return taps


@functools.lru_cache(maxsize=256)
def _byte_taps(n_old: int, n_new: int, channels: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_taps` along a row of ``channels``-byte texels, per output byte."""
    x0, x1, tx = _taps(n_old, n_new)
    byte = np.arange(channels, dtype=np.int32)
    taps = ((x0[:, None] * channels + byte).ravel(), (x1[:, None] * channels + byte).ravel(),
            np.repeat(tx, channels))
    for array in taps:
        array.setflags(write=False)
    return taps


@njit(cache=True, nogil=True)
def _reduce_kernel(src: np.ndarray, y0: np.ndarray, y1: np.ndarray, ty: np.ndarray,
                   x0: np.ndarray, x1: np.ndarray, tx: np.ndarray, even: bool, stride: int,
                   out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[i, k]``: the bilinear sample of ``src`` ((h, w * C) uint8 rows) with 8-bit weights,
    x then y, each lerp rounded half up; ``x0``, ``x1``, ``tx`` per output byte ``k`` (the
    channel's byte in the two source texels); ``even``: every weight is 128 and ``x1 = x0 +
    stride`` (an even width: the same numbers without the multiplications)."""
    n = out.shape[1]
    top = np.empty(n, np.int32)
    bottom = np.empty(n, np.int32)
    for i in range(out.shape[0]):
        ra, rb, wy = src[y0[i]], src[y1[i]], np.int32(ty[i])
        if even:  # byte c of texel j: bytes 2 j C + c and + C, weight 128: (a + b + 1) >> 1
            for j in range(n // stride):
                base = 2 * j * stride
                for c in range(stride):
                    top[j * stride + c] = (np.int32(ra[base + c]) + np.int32(ra[base + stride + c])
                                           + 1) >> 1
                    bottom[j * stride + c] = (np.int32(rb[base + c])
                                              + np.int32(rb[base + stride + c]) + 1) >> 1
        else:
            for k in range(n):
                a, b, wx = np.int32(x0[k]), np.int32(x1[k]), np.int32(tx[k])
                top[k] = (np.int32(ra[a]) * (256 - wx) + np.int32(ra[b]) * wx + 128) >> 8
                bottom[k] = (np.int32(rb[a]) * (256 - wx) + np.int32(rb[b]) * wx + 128) >> 8
        row = out[i]
        for k in range(n):
            row[k] = np.uint8((top[k] * (256 - wy) + bottom[k] * wy + 128) >> 8)


@njit(cache=True, nogil=True)
def _reduce_texels_kernel(src: np.ndarray, y0: np.ndarray, y1: np.ndarray, ty: np.ndarray,
                          x0: np.ndarray, x1: np.ndarray, tx: np.ndarray,
                          out: np.ndarray) -> None:  # pragma: no cover - compiled
    """:func:`_reduce_kernel` on four-byte texels, each a uint32 (``src``: (h, w), ``out``:
    (hn, wn)), the taps per texel: two channels at a time in the 16-bit halves of a word
    (``& 0x00FF00FF``, then the same after ``>> 8``). No lane can carry into the next:
    ``a * (256 - t) + b * t + 128 <= 255 * 256 + 128 < 2**16``, so each half holds exactly the
    per-channel sum, and ``>> 8`` then the mask gives each channel's rounded lerp."""
    m = np.uint32(0x00FF00FF)
    half = np.uint32(0x00800080)
    full = np.uint32(256)
    for i in range(out.shape[0]):
        ra, rb = src[y0[i]], src[y1[i]]
        wy = np.uint32(ty[i])
        vy = full - wy
        row = out[i]
        for j in range(out.shape[1]):
            a, b = x0[j], x1[j]
            wx = np.uint32(tx[j])
            vx = full - wx
            pa, pb, qa, qb = ra[a], ra[b], rb[a], rb[b]
            top_even = (((pa & m) * vx + (pb & m) * wx + half) >> 8) & m
            top_odd = ((((pa >> 8) & m) * vx + ((pb >> 8) & m) * wx + half) >> 8) & m
            bottom_even = (((qa & m) * vx + (qb & m) * wx + half) >> 8) & m
            bottom_odd = ((((qa >> 8) & m) * vx + ((qb >> 8) & m) * wx + half) >> 8) & m
            even = ((top_even * vy + bottom_even * wy + half) >> 8) & m
            odd = ((top_odd * vy + bottom_odd * wy + half) >> 8) & m
            row[j] = even | (odd << 8)


def reduce_level(level: np.ndarray) -> np.ndarray:
    """The next mip level of an ``(h, w, C)`` uint8 level (see the module docstring).

    Examples
    --------
    >>> level = np.array([[[0], [255]], [[10], [20]]], np.uint8)
    >>> reduce_level(level).tolist()  # rows 127.5 -> 128 and 15, then 71.5 -> 72
    [[[72]]]
    """
    h, w, channels = level.shape
    hn, wn = max(1, h // 2), max(1, w // 2)
    out = np.empty((hn, wn, channels), np.uint8)
    if channels == 4 and w != 2 * wn:  # an odd width: the texel kernel, ~1.5x faster
        _reduce_texels_kernel(np.ascontiguousarray(level).view(np.uint32).reshape(h, w),
                              *_taps(h, hn), *_taps(w, wn), out.view(np.uint32).reshape(hn, wn))
        return out
    _reduce_kernel(np.ascontiguousarray(level).reshape(h, w * channels), *_taps(h, hn),
                   *_byte_taps(w, wn, channels), w == 2 * wn, channels,
                   out.reshape(hn, wn * channels))
    return out


@njit(cache=True, nogil=True)
def _rgbx_kernel(rgb: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[k] = rgb[k]`` with a fourth byte 255 per texel (flat arrays)."""
    for k in range(out.shape[0] // 4):
        out[4 * k] = rgb[3 * k]
        out[4 * k + 1] = rgb[3 * k + 1]
        out[4 * k + 2] = rgb[3 * k + 2]
        out[4 * k + 3] = 255


def mip_chain(image: np.ndarray) -> list[np.ndarray]:
    """Every mip level of an ``(h, w, 3 or 4)`` uint8 image, level 0 first, down to 1 x 1; an
    RGB image is made RGBX (a fourth byte 255) first: four-byte texels are what GL stores, and
    what this module and llvmpipe's upload handle fastest.

    Examples
    --------
    >>> [lv.shape for lv in mip_chain(np.zeros((3, 5, 3), np.uint8))]
    [(3, 5, 4), (1, 2, 4), (1, 1, 4)]
    """
    if image.shape[2] == 3:
        h, w = image.shape[:2]
        rgbx = np.empty((h, w, 4), np.uint8)
        _rgbx_kernel(np.ascontiguousarray(image).reshape(-1), rgbx.reshape(-1))
        image = rgbx
    levels = [image]
    while levels[-1].shape[:2] != (1, 1):
        levels.append(reduce_level(levels[-1]))
    return levels
