"""Hand-picked tests of the census transform: bit order, comparisons, borders, errors."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.census import census_transform, hamming
from matcher.patterns import n_bits, n_words, spiral_offsets


def test_spiral_ring1_is_counter_clockwise_from_the_right():
    # (dy, dx), y down: right, up-right, up, up-left, left, down-left, down, down-right
    assert spiral_offsets(3).tolist() == [
        [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0], [1, 1]
    ]


def test_spiral_ring2_starts_right_and_goes_up_first():
    ring2 = spiral_offsets(5)[8:].tolist()
    assert ring2[:3] == [[0, 2], [-1, 2], [-2, 2]]
    assert ring2[-1] == [1, 2]
    assert len(ring2) == 16


@pytest.mark.parametrize("window", [3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23])
def test_spiral_covers_the_window_once_and_nests(window):
    off = spiral_offsets(window)
    r = window // 2
    assert off.shape == (window * window - 1, 2)
    assert len({tuple(p) for p in off.tolist()}) == len(off)
    assert np.abs(off).max() == r and not (off == 0).all(axis=1).any()
    if window > 3:
        small = spiral_offsets(window - 2)
        np.testing.assert_array_equal(off[: len(small)], small)


def test_single_dark_pixel_sets_the_bit_of_its_offset():
    img = np.full((7, 7), 10, np.uint8)
    img[3, 3] = 0
    codes = census_transform(img, window=3)[..., 0]
    # a neighbour p sees the dark pixel at offset (3 - y, 3 - x); its bit index in ring 1:
    expected = np.zeros((7, 7), np.uint64)
    for k, (dy, dx) in enumerate(spiral_offsets(3).tolist()):
        expected[3 - dy, 3 - dx] = np.uint64(1) << np.uint64(k)
    np.testing.assert_array_equal(codes, expected)
    assert int(codes[3, 2]) == 1  # dark pixel right of (3, 2): bit 0
    assert int(codes[4, 3]) == 4  # dark pixel above (4, 3): bit 2
    assert int(codes[3, 3]) == 0  # the dark pixel itself is never brighter


def test_single_bright_pixel_has_all_bits_set():
    img = np.zeros((9, 9), np.float32)
    img[4, 4] = 1.0
    codes = census_transform(img, window=9)
    assert n_bits(9) == 80 and codes.shape == (9, 9, 2)
    assert int(codes[4, 4, 0]) == 2**64 - 1 and int(codes[4, 4, 1]) == 2**16 - 1
    codes[4, 4] = 0
    assert not codes.any()  # the dark pixels never exceed a neighbour


def test_constant_image_gives_zero_codes():
    assert not census_transform(np.full((12, 10, 3), 77, np.uint8), window=7).any()


def test_border_replicates_the_edge():
    img = np.array([[0, 5, 9]] * 3, np.uint8)
    code = int(census_transform(img, window=3)[1, 2, 0])
    # at (1, 2): right column is replicated (9 vs 9: 0); left neighbours are 5 (bits 3, 4, 5)
    assert code == (1 << 3) | (1 << 4) | (1 << 5)


def test_float64_comparisons_are_exact():
    img = np.zeros((3, 3))
    img[1, 1] = 1e-300  # float32 would flush this to 0
    assert int(census_transform(img, window=3)[1, 1, 0]) == 255


def test_rgb_is_converted_to_grey():
    rgb = np.zeros((5, 5, 3), np.uint8)
    rgb[2, 2] = (255, 0, 0)
    assert int(census_transform(rgb, window=3)[2, 2, 0]) == 255


def test_hamming_hand_example_and_words():
    a = np.array([[0b1011, 0], [2**63, 1]], np.uint64)
    b = np.array([[0b0001, 0], [0, 0]], np.uint64)
    np.testing.assert_array_equal(hamming(a, b), [2, 2])
    assert n_words(64) == 1 and n_words(65) == 2 and n_bits(21) == 440


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"window": 4}, ValueError, "window: expected an odd"),
        ({"window": 1}, ValueError, "window: expected an odd"),
        ({"window": 13}, ValueError, "at most min"),
        ({"window": 3.0}, TypeError, "window: expected an integer"),
        ({"window": 3, "pattern": "star"}, ValueError, "pattern"),
        ({"window": 3, "pattern": np.array([[2, 0]])}, ValueError, r"\|dy\|, \|dx\| <= 1"),
        ({"window": 3, "pattern": np.array([[0, 0]])}, ValueError, "non-zero"),
        ({"window": 3, "pattern": np.zeros((2, 3), int)}, ValueError, r"\(n, 2\)"),
    ],
)
def test_bad_arguments(kwargs, error, match):
    with pytest.raises(error, match=match):
        census_transform(np.zeros((12, 12), np.uint8), **kwargs)


def test_bad_images():
    with pytest.raises(ValueError, match="NaN"):
        census_transform(np.full((5, 5), np.nan), window=3)
    with pytest.raises(TypeError, match="image"):
        census_transform([[1, 2], [3, 4]], window=3)
    with pytest.raises(TypeError, match="uint64"):
        hamming(np.zeros(2, np.int64), np.zeros(2, np.uint64))
