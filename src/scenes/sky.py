"""A sky at infinity: a scene's colour in every direction no surface covers.

A :class:`SkySpec` on a scene (``SceneSpec.sky``) replaces its flat ``background``. Its colour
depends on the viewing *direction* only, never on the eye's position, so the two cameras of a
rectified rig (one orientation, centres a baseline apart) see the same sky value at the same
pixel: the sky's disparity is exactly 0, and the renderer's ground truth says so (disparity 0,
depth ``inf`` and a sky mask where no surface is hit; ``docs/ground-truth.md``).

The colour of a unit direction ``d`` (OpenCV axes: ``y`` down, so up is ``-y``) at elevation
``e = asin(-d_y)``, display-encoded in [0, 1]:

- above the horizon, ``horizon`` blended toward ``zenith`` with weight ``sqrt(e / 90 deg)``,
  and clouds over it: the sky's seeded fractal noise (four octaves of
  :func:`scenes.textures.band_limited_noise` on a periodic tile) sampled where the direction
  meets a cloud layer one unit above the eye (``(d_x, d_z) / -d_y``, ``cloud_scale`` tiles per
  unit), turned into a cover of ``clouds`` (0: clear, 1: overcast) and faded toward the
  horizon, where the layer's texture would alias;
- below it, ``horizon`` blended toward ``ground`` over the first ``HAZE_DEG`` degrees: far land
  in haze, behind whatever ground a scene has.

A pitched rig (``SkySpec.pitch``) first turns each direction back to the level frame. Everything
is a pure function of the spec (:class:`scenes.skyspec.SkySpec`) and the direction
(:func:`sky_colour`), in numpy.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from scenes.skyspec import SkySpec
from scenes.textures import band_limited_noise

__all__ = ["SkySpec", "sky_colour", "HAZE_DEG"]

#: Degrees below the horizon over which the sky's colour turns from ``horizon`` to ``ground``.
HAZE_DEG = 4.0
_TILE = 256  # side of the periodic cloud tile, texels
_OCTAVES = (4.0, 8.0, 16.0, 32.0)  # cycles per tile of the cloud noise's octaves


@functools.lru_cache(maxsize=8)
def _cloud_tile(seed: int) -> np.ndarray:
    """(T, T) float32 fractal noise of ``seed`` scaled to about [0, 1] (periodic: it tiles)."""
    rng = np.random.default_rng(seed)
    tile = np.zeros((_TILE, _TILE), np.float32)
    for k, f in enumerate(_OCTAVES):
        tile += np.float32(0.5 ** k) * band_limited_noise(
            (_TILE, _TILE), frequency=f, pixel_size=(1.0 / _TILE, 1.0 / _TILE), rng=rng)
    tile *= np.float32(1.0 / math.sqrt(sum(0.25 ** k for k in range(len(_OCTAVES)))))
    tile = np.clip(0.5 + 0.2 * tile, 0.0, 1.0)  # unit variance -> ~[0, 1] within 2.5 sigma
    tile.setflags(write=False)
    return tile


def _sample_wrapped(tile: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear samples of a periodic ``tile`` at texel coordinates ``u`` (columns), ``v``."""
    n = tile.shape[0]
    u0, v0 = np.floor(u), np.floor(v)
    tu, tv = (u - u0).astype(np.float32), (v - v0).astype(np.float32)
    i0, k0 = (u0.astype(np.int64) % n), (v0.astype(np.int64) % n)
    i1, k1 = (i0 + 1) % n, (k0 + 1) % n
    top = tile[k0, i0] * (1 - tu) + tile[k0, i1] * tu
    bottom = tile[k1, i0] * (1 - tu) + tile[k1, i1] * tu
    return top * (1 - tv) + bottom * tv


def _smoothstep(lo: float, hi: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def sky_colour(sky: SkySpec, directions: np.ndarray) -> np.ndarray:
    """The sky's display-encoded colour in each direction.

    Parameters
    ----------
    sky : SkySpec
    directions : (N, 3) float array
        View directions (OpenCV axes; any non-zero length).

    Returns
    -------
    colour : (N, 3) float32 array
        RGB in [0, 1].

    Examples
    --------
    >>> up, ahead = sky_colour(SkySpec(clouds=0.0), np.array([[0, -1.0, 0], [0, 0, 1.0]]))
    >>> [round(float(c), 3) for c in up], [round(float(c), 3) for c in ahead]
    ([0.35, 0.55, 0.85], [0.75, 0.82, 0.9])
    """
    d = np.asarray(directions, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    if sky.pitch:  # camera -> level frame: X_level = Rx(-pitch) X_camera
        a = math.radians(sky.pitch)
        c, s = math.cos(a), math.sin(a)
        d = np.stack([d[:, 0], c * d[:, 1] + s * d[:, 2], -s * d[:, 1] + c * d[:, 2]], axis=1)
    rise = -d[:, 1]  # sin(elevation)
    elevation = np.arcsin(np.clip(rise, -1.0, 1.0))
    zenith, horizon, ground = (np.asarray(c, np.float64) for c in
                               (sky.zenith, sky.horizon, sky.ground))
    up = np.sqrt(np.clip(elevation / (math.pi / 2), 0.0, 1.0))[:, None]
    down = np.clip(-elevation / math.radians(HAZE_DEG), 0.0, 1.0)[:, None]
    colour = np.where(rise[:, None] >= 0, horizon + (zenith - horizon) * up,
                      horizon + (ground - horizon) * down)
    above = rise > 1e-3
    if sky.clouds > 0 and np.any(above):
        reach = 1.0 / rise[above]  # where the direction meets the layer one unit up
        scale = sky.cloud_scale * _TILE
        density = _sample_wrapped(_cloud_tile(sky.seed), d[above, 0] * reach * scale,
                                  d[above, 2] * reach * scale).astype(np.float64)
        threshold = 1.0 - sky.clouds
        cover = _smoothstep(threshold - 0.15, threshold + 0.15, density)
        cover *= _smoothstep(0.03, 0.25, rise[above])  # fade toward the horizon (aliasing)
        cloud = np.asarray(sky.cloud_colour, np.float64)
        colour[above] += (cloud - colour[above]) * cover[:, None]
    return np.clip(colour, 0.0, 1.0).astype(np.float32)
