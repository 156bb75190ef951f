"""Hand examples and bad input for matcher.haar."""

from __future__ import annotations

import numpy as np
import pytest

from matcher.haar import HaarBands, haar2d, ihaar2d


def test_block_formulas_average_and_orthonormal():
    # [[a, b], [c, d]] = [[4, 2], [0, 2]]
    img = np.array([[4, 2], [0, 2]], np.uint8)
    avg = haar2d(img, norm="average")
    assert (avg.ll[0, 0], avg.lh[0, 0], avg.hl[0, 0], avg.hh[0, 0]) == (2.0, 1.0, 0.0, 1.0)
    ortho = haar2d(img)
    assert (ortho.ll[0, 0], ortho.lh[0, 0], ortho.hl[0, 0], ortho.hh[0, 0]) == (4.0, 2.0, 0.0, 2.0)


def test_band_naming_follows_the_paper():
    # Vertical stripes (change along x): horizontal high -> HL, not LH.
    stripes = np.tile(np.array([10.0, 0.0]), (4, 2))
    b = haar2d(stripes, norm="average")
    assert np.all(b.hl == 5.0) and np.all(b.lh == 0.0) and np.all(b.hh == 0.0)
    # Horizontal stripes (change along y): vertical high -> LH.
    b = haar2d(stripes.T.copy(), norm="average")
    assert np.all(b.lh == 5.0) and np.all(b.hl == 0.0)


def test_odd_sizes_are_replicate_padded_and_cropped_back():
    img = np.arange(15, dtype=np.float64).reshape(3, 5)
    b = haar2d(img, norm="average")
    assert b.ll.shape == (2, 3) and b.shape == (3, 5)
    # last block column is [4, 4] / [9, 9] (column 4 replicated): no horizontal detail
    assert b.hl[0, 2] == 0.0
    # last block row: row 2 replicated, so no vertical detail
    assert np.all(b.lh[1] == 0.0)
    assert ihaar2d(b).shape == (3, 5)
    np.testing.assert_allclose(ihaar2d(b), img, rtol=0, atol=1e-12)


def test_rgb_input_is_converted_to_grey():
    rgb = np.zeros((4, 4, 3), np.uint8)
    rgb[..., 1] = 100
    b = haar2d(rgb, norm="average")
    assert np.all(b.ll == 59.0)  # round(0.587 * 100)


def test_bad_input():
    with pytest.raises(ValueError, match="norm"):
        haar2d(np.zeros((4, 4)), norm="l2")
    with pytest.raises(TypeError, match="image"):
        haar2d([[1, 2], [3, 4]])
    with pytest.raises(TypeError, match="bands"):
        ihaar2d(np.zeros((2, 2)))
    b = haar2d(np.zeros((4, 4)))
    bad = HaarBands(ll=b.ll, lh=b.lh[:1], hl=b.hl, hh=b.hh, shape=b.shape, norm=b.norm)
    with pytest.raises(ValueError, match="bands"):
        ihaar2d(bad)
