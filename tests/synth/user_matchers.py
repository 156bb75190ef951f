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
