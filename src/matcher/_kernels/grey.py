"""RGB to grey of uint8 images in one pass (the formula of :func:`matcher._validation.rgb_to_grey`).

``grey = floor(x + 0.5)`` clipped to 0..255 with ``x = fma(b, 0.114, fma(r, 0.299, g * 0.587))``
in float64: the BT.601 weighted sum in the order (and with the fused multiply-adds) that numpy's
``image.astype(float64) @ (0.299, 0.587, 0.114)`` used before this kernel. The order matters only
where the exact sum ``(299 r + 587 g + 114 b) / 1000`` ends in ``.5`` (16,782 of the 2**24
colours): there rounding decides; ``tests/matcher/test_grey_kernel.py`` checks every colour.
About 4x faster than the float64 matrix product and its three temporary arrays; one flat loop
over the pixels, which LLVM vectorises (a row and column loop did not: ~3x slower, ~1 ms for a
960 x 540 image).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from matcher._kernels.intrinsics import fma

__all__ = ["grey_uint8_kernel"]


@njit(cache=True, nogil=True)
def grey_uint8_kernel(image: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[i, j]`` = the grey level of the (H, W, 3) uint8 RGB ``image[i, j]`` (see above);
    both C-contiguous."""
    rgb = image.reshape(-1)
    grey = out.reshape(-1)
    for k in range(grey.size):
        x = fma(float(rgb[3 * k + 2]), 0.114,
                fma(float(rgb[3 * k]), 0.299, float(rgb[3 * k + 1]) * 0.587))
        grey[k] = np.uint8(min(max(np.floor(x + 0.5), 0.0), 255.0))
