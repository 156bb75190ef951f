"""Property tests of the census transform against a slow reference, each beside a hand example."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matcher.census import census_transform, hamming
from matcher.patterns import sparse_pattern, spiral_offsets
from matcher.testing import grey_images


def reference_census(image: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Slow, obvious census: one pixel and one bit at a time, edge replicated."""
    img = np.asarray(image, dtype=np.float64)
    h, w = img.shape
    words = (len(offsets) + 63) // 64
    out = np.zeros((h, w, words), dtype=np.uint64)
    for y in range(h):
        for x in range(w):
            for k, (dy, dx) in enumerate(offsets):
                yy = min(max(y + dy, 0), h - 1)
                xx = min(max(x + dx, 0), w - 1)
                if img[y, x] > img[yy, xx]:
                    out[y, x, k // 64] |= np.uint64(1) << np.uint64(k % 64)
    return out


def test_matches_the_reference_on_a_fixed_image():
    rng = np.random.default_rng(7)
    img = rng.integers(0, 8, (11, 13)).astype(np.uint8)  # few levels: many ties
    for window in (3, 5, 11):
        np.testing.assert_array_equal(
            census_transform(img, window=window), reference_census(img, spiral_offsets(window))
        )


def test_custom_pattern_keeps_its_order():
    img = np.random.default_rng(1).integers(0, 255, (9, 9)).astype(np.uint8)
    pattern = np.array([[2, 2], [0, -1], [-2, 0]])
    codes = census_transform(img, window=5, pattern=pattern)
    np.testing.assert_array_equal(codes, reference_census(img, pattern))


@given(
    img=grey_images(min_side=3, max_side=24, levels=6),
    window=st.sampled_from([3, 5, 7, 9]),
    pattern=st.sampled_from(["dense", "sparse"]),
)
def test_census_equals_reference(img, window, pattern):
    side = min(img.shape)
    window = min(window, side if side % 2 else side - 1)  # the largest odd window that fits
    offsets = spiral_offsets(window) if pattern == "dense" else sparse_pattern(window)
    np.testing.assert_array_equal(
        census_transform(img, window=window, pattern=pattern), reference_census(img, offsets)
    )


@given(img=grey_images(min_side=21, max_side=32, levels=16), window=st.sampled_from([3, 5, 7, 9, 11]))
def test_smaller_window_code_is_a_prefix(img, window):
    small = census_transform(img, window=window)
    large = census_transform(img, window=21)
    k = window * window - 1
    bits_small = np.unpackbits(small.view(np.uint8), axis=-1, bitorder="little")[..., :k]
    bits_large = np.unpackbits(large.view(np.uint8), axis=-1, bitorder="little")[..., :k]
    np.testing.assert_array_equal(bits_small, bits_large)


def test_prefix_hand_example():
    img = np.arange(25 * 25, dtype=np.float32).reshape(25, 25) % 7
    small = census_transform(img, window=3)[..., 0]
    large = census_transform(img, window=5)[..., 0]
    np.testing.assert_array_equal(small, large & np.uint64(0xFF))


@given(
    a=st.lists(st.integers(0, 2**64 - 1), min_size=2, max_size=2),
    b=st.lists(st.integers(0, 2**64 - 1), min_size=2, max_size=2),
    c=st.lists(st.integers(0, 2**64 - 1), min_size=2, max_size=2),
)
def test_hamming_is_a_metric(a, b, c):
    a, b, c = (np.array(v, np.uint64) for v in (a, b, c))
    assert hamming(a, b) == hamming(b, a)
    assert hamming(a, a) == 0
    assert hamming(a, c) <= hamming(a, b) + hamming(b, c)
    assert hamming(a, b) == sum(bin(int(x) ^ int(y)).count("1") for x, y in zip(a, b, strict=True))


def test_hamming_metric_hand_example():
    a, b, c = (np.array([v], np.uint64) for v in (0b1100, 0b1010, 0b0110))
    assert (hamming(a, b), hamming(b, c), hamming(a, c)) == (2, 2, 2)


@given(img=grey_images(min_side=5, max_side=24, levels=8), window=st.sampled_from([3, 5, 9, 11]))
def test_uint8_and_float_kernels_agree(img, window):
    side = min(img.shape)
    window = min(window, side if side % 2 else side - 1)
    codes = census_transform(img, window=window)
    np.testing.assert_array_equal(census_transform(img.astype(np.float32), window=window), codes)
    np.testing.assert_array_equal(census_transform(img / 7.0, window=window), codes)  # float64


def test_uint8_and_float_kernels_agree_hand_example():
    img = np.array([[3, 1, 4, 1], [5, 9, 2, 6], [5, 3, 5, 8]], np.uint8)
    codes = census_transform(img, window=3)
    np.testing.assert_array_equal(census_transform(img.astype(np.float32), window=3), codes)
    assert int(codes[1, 1, 0]) == 0b11111111  # 9 beats all eight neighbours
    assert int(codes[1, 2, 0]) == 0b00001010  # 2 beats only the 1s above-right (bit 1), above-left (bit 3)
