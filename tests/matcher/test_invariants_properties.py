"""Census invariants every census matcher must keep, with hand-picked examples beside them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from matcher import census_transform, match, n_bits
from matcher import testing as mst

PATTERNS = ("dense", "sparse")


# ---------------------------------------------------------------- monotone intensity maps
def test_monotone_map_hand_example():
    img = np.array([[10, 20, 30], [40, 25, 60], [70, 80, 25]], dtype=np.uint8)
    codes = census_transform(img, window=3)
    mapped = census_transform(2.0 * img.astype(np.float64) + 7.0, window=3)
    gamma = census_transform(255.0 * (img / 255.0) ** 0.4, window=3)
    assert np.array_equal(codes, mapped) and np.array_equal(codes, gamma)
    # the centre (25) is brighter than 10 and 20 only: bits of offsets (-1,-1) and (-1,0)
    assert codes[1, 1, 0] != 0


@given(img=mst.grey_images(min_side=5, max_side=24, levels=16), lut=mst.monotone_maps(),
       window=mst.windows(max_size=9), pattern=st.sampled_from(PATTERNS))
def test_codes_invariant_under_strictly_increasing_maps(img, lut, window, pattern):
    window = min(window, *img.shape) // 2 * 2 + 1 if min(img.shape) < window else window
    if window > min(img.shape):
        window -= 2
    mapped = lut[img].astype(np.float64)
    assert np.array_equal(census_transform(img, window=window, pattern=pattern),
                          census_transform(mapped, window=window, pattern=pattern))


# ---------------------------------------------------------------- translation equivariance
def test_translation_hand_example():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (12, 14), dtype=np.uint8)
    moved = np.roll(img, (2, 3), axis=(0, 1))
    a, b = census_transform(img, window=3), census_transform(moved, window=3)
    assert np.array_equal(a[1:9, 1:10], b[3:11, 4:13])


@given(img=mst.grey_images(min_side=16, max_side=32), window=mst.windows(max_size=7),
       dy=st.integers(-4, 4), dx=st.integers(-4, 4), pattern=st.sampled_from(PATTERNS))
def test_codes_are_translation_equivariant_away_from_borders(img, window, dy, dx, pattern):
    moved = np.roll(img, (dy, dx), axis=(0, 1))
    a = census_transform(img, window=window, pattern=pattern)
    b = census_transform(moved, window=window, pattern=pattern)
    r = window // 2
    h, w = img.shape
    # pixels whose window lies inside the image both before and after the move (no wrap-around)
    ys = slice(r + max(0, -dy), h - r - max(0, dy))
    xs = slice(r + max(0, -dx), w - r - max(0, dx))
    ys2 = slice(ys.start + dy, ys.stop + dy)
    xs2 = slice(xs.start + dx, xs.stop + dx)
    assert np.array_equal(a[ys, xs], b[ys2, xs2])


# ---------------------------------------------------------------- identical views and shifts
CENSUS_METHODS = ("ct", "sct", "cthw", "awct", "awsct")


@pytest.mark.parametrize("method", CENSUS_METHODS)
def test_identical_views_give_zero_hand_example(method):
    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, (32, 40), dtype=np.uint8)
    disp = match(img, img, method=method, window=7, max_disparity=8).disparity
    assert np.all(disp == 0)


@given(img=mst.textured_images(min_side=24, max_side=40), method=st.sampled_from(CENSUS_METHODS),
       window=mst.windows(min_size=3, max_size=9))
def test_identical_views_give_zero(img, method, window):
    disp = match(img, img, method=method, window=window, max_disparity=8).disparity
    assert np.all(disp == 0)


def _interior(pair: mst.ShiftedPair, margin: int) -> tuple[slice, slice]:
    h, w = pair.left.shape
    return slice(margin, h - margin), slice(pair.shift + margin, w - margin)


def _prefix_hamming(a: np.ndarray, b: np.ndarray, bits: int) -> int:
    """Hamming distance of the first ``bits`` bits of two packed codes (bit i in word i // 64)."""
    total = 0
    for k in range(a.shape[0]):
        take = min(64, bits - 64 * k)
        if take <= 0:
            break
        mask = np.uint64((1 << take) - 1) if take < 64 else np.uint64(2**64 - 1)
        total += int(np.bitwise_count((a[k] ^ b[k]) & mask))
    return total


def _check_shift(result, pair: mst.ShiftedPair, method: str, window: int, max_disparity: int) -> None:
    """Census WTA on a pure shift: the true d costs 0, so WTA must pick the SMALLEST zero-cost d.

    A census code can repeat within the search range (a local minimum of its window has the all-zero
    code, a maximum all ones); then the smaller d wins the tie, by the documented rule. Where the
    true code is unique among the candidates, the answer is exactly the shift.
    """
    pattern = "sparse" if method in ("sct", "awsct") else "dense"
    cl = census_transform(pair.left, window=window, pattern=pattern)
    cr = census_transform(pair.right, window=window, pattern=pattern)
    windows = getattr(result, "window_map", None)
    ys, xs = _interior(pair, window // 2 + 1)
    exact = total = 0
    for y in range(ys.start, ys.stop):
        for x in range(xs.start, xs.stop):
            w = window if windows is None else int(windows[y, x])
            bits = n_bits(w, pattern)
            zero = [d for d in range(min(max_disparity, x + 1))
                    if _prefix_hamming(cl[y, x], cr[y, x - d], bits) == 0]
            assert pair.shift in zero
            assert result.disparity[y, x] == min(zero), (y, x, zero)
            exact += int(result.disparity[y, x] == pair.shift)
            total += 1
    assert exact >= 0.9 * total


def test_known_shift_hand_example_with_ties():
    rng = np.random.default_rng(3)
    strip = rng.integers(0, 256, (40, 70), dtype=np.uint8)
    left, right = strip[:, :64], strip[:, 6:70]  # left x matches right x - 6
    disp = match(left, right, method="ct", window=9, max_disparity=12).disparity
    inner = disp[6:-6, 12:-6]
    misses = {(int(y) + 6, int(x) + 12): float(inner[y, x]) for y, x in zip(*np.nonzero(inner != 6))}
    # three local extrema whose 80-bit code repeats at a smaller d (zero-cost ties)
    assert misses == {(14, 48): 1.0, (14, 50): 3.0, (26, 34): 2.0}
    assert census_transform(left, window=9)[14, 48].tolist() == [0, 0]  # a local minimum


@pytest.mark.parametrize("method", ("ct", "sct", "awct", "awsct"))
def test_known_shift_hand_example(method):
    rng = np.random.default_rng(3)
    strip = rng.integers(0, 256, (40, 70), dtype=np.uint8)
    pair = mst.ShiftedPair(left=strip[:, :64], right=strip[:, 6:70], shift=6)
    result = match(pair.left, pair.right, method=method, window=9, max_disparity=12)
    _check_shift(result, pair, method, 9, 12)


def test_cthw_known_shift_hand_example():
    rng = np.random.default_rng(3)
    strip = rng.integers(0, 256, (40, 70), dtype=np.uint8)
    disp = match(strip[:, :64], strip[:, 6:70], method="cthw", window=9, max_disparity=12).disparity
    assert np.mean(np.abs(disp[10:-10, 16:-10] - 6) <= 1) == 1.0


@given(pair=mst.shifted_pairs(max_shift=8, min_side=32, max_side=48),
       method=st.sampled_from(("ct", "sct", "awct", "awsct")), window=st.sampled_from((7, 9, 11)))
def test_known_shift_is_recovered_exactly(pair, method, window):
    result = match(pair.left, pair.right, method=method, window=window, max_disparity=10)
    _check_shift(result, pair, method, window, 10)


@given(pair=mst.shifted_pairs(max_shift=8, min_side=32, max_side=48, smooth=(1.5, 2.5)),
       window=st.sampled_from((7, 9, 11)))
def test_cthw_recovers_a_shift_within_one_pixel(pair, window):
    # CTHW matches the half-resolution LL bands: an odd shift is a half-pixel shift there, which
    # a census of white noise cannot follow (aliasing: ~80 % within 1 px, measured); textures
    # band-limited below the half-resolution Nyquist frequency are recovered everywhere.
    disp = match(pair.left, pair.right, method="cthw", window=window, max_disparity=10).disparity
    ys, xs = _interior(pair, window + 2)
    assert np.all(np.abs(disp[ys, xs] - pair.shift) <= 1)


@given(pair=mst.shifted_pairs(max_shift=8, min_side=32, max_side=48), window=st.sampled_from((7, 9, 11)))
def test_cthw_recovers_an_even_shift_of_any_texture(pair, window):
    if pair.shift % 2:
        pair = mst.ShiftedPair(pair.left[:, 1:], pair.right[:, :-1], pair.shift - 1)
    disp = match(pair.left, pair.right, method="cthw", window=window, max_disparity=10).disparity
    ys, xs = _interior(pair, window + 2)
    assert np.all(np.abs(disp[ys, xs] - pair.shift) <= 1)
