"""``rgb_to_grey`` of uint8 images (the kernel ``matcher._kernels.grey``) on every RGB colour.

Where the exact BT.601 sum ``(299 r + 587 g + 114 b) / 1000`` is not halfway between two
integers the grey level is that sum rounded; at the 16,782 halfway colours it is decided by the
float64 rounding of ``fma(b, 0.114, fma(r, 0.299, g * 0.587))``, emulated here with exact
fractions (one rounding per operation), so the check holds on any CPU.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from matcher._validation import GREY_WEIGHTS, rgb_to_grey


def _all_colours() -> np.ndarray:
    c = np.arange(1 << 24, dtype=np.uint32)
    rgb = np.stack([(c >> 16) & 255, (c >> 8) & 255, c & 255], axis=-1).astype(np.uint8)
    return rgb.reshape(4096, 4096, 3)


def _rounded(x: Fraction) -> float:
    return float(x)  # Fraction -> nearest float64 (ties to even): one IEEE rounding


def _grey_of_tie(r: int, g: int, b: int) -> int:
    wr, wg, wb = (Fraction(w) for w in GREY_WEIGHTS)  # the float64 weights, exactly
    inner = _rounded(Fraction(r) * wr + Fraction(_rounded(Fraction(g) * wg)))
    x = _rounded(Fraction(b) * wb + Fraction(inner))
    return int(np.floor(x + 0.5))


def test_every_colour_matches_the_weighted_sum_and_its_float64_rounding_at_ties():
    img = _all_colours()
    grey = rgb_to_grey(img).ravel()
    rgb = img.reshape(-1, 3).astype(np.int64)
    exact = 299 * rgb[:, 0] + 587 * rgb[:, 1] + 114 * rgb[:, 2]  # 1000 x the sum
    tie = exact % 1000 == 500
    assert int(tie.sum()) == 16_782
    np.testing.assert_array_equal(grey[~tie], (exact[~tie] + 500) // 1000)
    ties = np.flatnonzero(tie)
    expected = [_grey_of_tie(*map(int, rgb[i])) for i in ties]
    np.testing.assert_array_equal(grey[ties], expected)
    # the halfway colours go both ways: the float64 rounding is what the test pins
    assert 0 < int((grey[ties] == exact[ties] // 1000).sum()) < ties.size


def test_strided_and_read_only_images_give_the_contiguous_result():
    img = np.random.default_rng(0).integers(0, 256, (9, 14, 3), dtype=np.uint8)
    expected = rgb_to_grey(np.ascontiguousarray(img[:, ::2]))
    view = img[:, ::2]
    view.setflags(write=False)
    np.testing.assert_array_equal(rgb_to_grey(view), expected)
    assert rgb_to_grey(view).dtype == np.uint8
