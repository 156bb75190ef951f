"""OpenCV's StereoBM as a user matcher of docs/validate.md (the built-in ``bm:9`` is the same).

    stereoforge validate py:docs/examples/opencv_bm.py:stereo_bm --out out/validate-bm
"""

import cv2
import numpy as np


def stereo_bm_raw(left, right, *, max_disparity):
    """StereoBM as most code calls it: fixed-point output / 16 (``-1`` where it found nothing)."""
    bm = cv2.StereoBM_create(numDisparities=16 * -(-max_disparity // 16), blockSize=9)
    grey = [cv2.cvtColor(v, cv2.COLOR_RGB2GRAY) for v in (left, right)]
    return bm.compute(*grey).astype(np.float32) / 16.0


def stereo_bm(left, right, *, max_disparity):
    """The same, with "no estimate" marked ``inf`` as stereoforge expects."""
    disparity = stereo_bm_raw(left, right, max_disparity=max_disparity)
    disparity[disparity < 0] = np.inf
    return disparity
