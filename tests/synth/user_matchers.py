"""Tiny user matchers the validate and study tests name by path (``py:<this file>:sad3``)."""

from __future__ import annotations

import numpy as np


def sad3(left, right, *, max_disparity):
    """SAD over a 3x3 box, winner takes all; NaN where the search leaves the right image."""
    import cv2

    gl, gr = left.mean(axis=2, dtype=np.float32), right.mean(axis=2, dtype=np.float32)
    w = gl.shape[1]
    costs = np.full((max_disparity, *gl.shape), np.inf, np.float32)
    for d in range(max_disparity):
        costs[d, :, d:] = cv2.boxFilter(np.abs(gl[:, d:] - gr[:, : w - d]), -1, (3, 3))
    disp = costs.argmin(axis=0).astype(np.float32)
    disp[:, :max_disparity] = np.nan
    return disp


def broken(left, right, *, max_disparity):
    raise ZeroDivisionError("user bug")


def sleepy(left, right, *, max_disparity):
    """Hangs on its first call ever (it leaves the file $HANG_MARKER behind), answers later."""
    import os
    import time

    marker = os.environ["HANG_MARKER"]
    if not os.path.exists(marker):
        open(marker, "w").close()
        time.sleep(60)
    return np.zeros(left.shape[:2], np.float32)


def sensor_noise(image):
    """Sensor noise sigma of an (H, W, 3) image, grey levels: Immerkaer's estimator (Immerkaer
    1996, "Fast noise variance estimation") on the difference of the red and green channels,
    divided by sqrt 2. Sensor noise is independent per channel while the scene is nearly grey,
    so the difference holds little but the noise (about 1 for validate's 1 grey level)."""
    from scipy.signal import convolve2d

    diff = image[..., 0].astype(np.float64) - image[..., 1].astype(np.float64)
    kernel = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float64)
    h, w = diff.shape
    total = np.abs(convolve2d(diff, kernel, mode="valid")).sum()
    return float(np.sqrt(np.pi / 2) / (6 * (w - 2) * (h - 2)) * total / np.sqrt(2))


#: Share of the pixels ct9_worse_under_noise corrupts on a noisy pair.
CORRUPTED = 0.08


def ct9_worse_under_noise(left, right, *, max_disparity):
    """CT-9 made worse under sensor noise only, a planted regression: on a pair whose left view
    has noise above 2.5 grey levels (:func:`sensor_noise`), 8 % of the pixels (drawn from a
    seed made of the image's bytes, so the answer is deterministic) get an estimate half the
    search range away from CT-9's."""
    import zlib

    from matcher import match

    disp = match(left, right, method="ct", window=9, max_disparity=max_disparity).disparity
    if sensor_noise(left) > 2.5:
        rng = np.random.default_rng(zlib.crc32(left.tobytes()))
        pick = rng.random(disp.shape) < CORRUPTED
        disp[pick] = (disp[pick] + max_disparity // 2) % max_disparity
    return disp
