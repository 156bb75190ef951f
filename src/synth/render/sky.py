"""The sky at infinity of a scene (:mod:`scenes.sky`) under its rendered surfaces.

The colour pass of a scene with a sky clears to transparent black; the multisampled resolve
then holds, per pixel, the surfaces' colour times their coverage ``a`` (premultiplied) and ``a``
itself. :func:`over_sky` puts that over the sky seen through each pixel centre:
``out = rgb + (1 - a) * sky(K^-1 (x, y, 1))``, rounded. The sky's value depends on the pixel's
direction only, so both cameras of a rectified rig get the same value at the same pixel
(disparity 0, exactly; :mod:`synth.pair` labels those pixels).
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["over_sky"]


def over_sky(rgba: np.ndarray, sky: Any, rig: Any) -> np.ndarray:
    """(H, W, 3) uint8: the premultiplied ``rgba`` (H, W, 4) uint8 over ``sky`` (a
    :class:`scenes.sky.SkySpec`) seen through ``rig``'s pixel centres (OpenCV intrinsics, the
    world's orientation)."""
    from scenes.sky import sky_colour

    rgb = np.ascontiguousarray(rgba[..., :3])
    alpha = rgba[..., 3]
    rows, cols = np.nonzero(alpha < 255)  # the sky shows only where coverage is not full
    if rows.size == 0:
        return rgb
    directions = np.stack([(cols - rig.cx) / rig.fx, (rows - rig.cy) / rig.fy,
                           np.ones(rows.size)], axis=1)
    clear = (255.0 - alpha[rows, cols].astype(np.float32)) * np.float32(1.0 / 255.0)
    seen = rgb[rows, cols].astype(np.float32) + clear[:, None] * 255.0 * sky_colour(sky, directions)
    rgb[rows, cols] = np.clip(np.rint(seen), 0, 255).astype(np.uint8)
    return rgb
