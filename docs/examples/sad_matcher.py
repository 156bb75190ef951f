"""A 20-line SAD block matcher: the user matcher of docs/validate.md.

    stereoforge validate py:docs/examples/sad_matcher.py:sad --out out/validate-sad
"""

import numpy as np
from scipy.ndimage import uniform_filter


def sad(left, right, *, max_disparity, window=7):
    """Left disparity of a rectified (H, W, 3) uint8 pair: SAD over window x window blocks, WTA."""
    grey_l = left.astype(np.float32).mean(axis=2)
    grey_r = right.astype(np.float32).mean(axis=2)
    h, w = grey_l.shape
    cost = np.full((max_disparity, h, w), np.inf, dtype=np.float32)
    for d in range(max_disparity):  # left x matches right x - d; columns x < d have no match
        diff = np.abs(grey_l[:, d:] - grey_r[:, : w - d])
        cost[d, :, d:] = uniform_filter(diff, size=window, mode="nearest")
    return cost.argmin(axis=0).astype(np.float32)
