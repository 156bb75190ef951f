"""Hypothesis strategies for property-testing stereo matchers (ours or yours).

Everything here is made with numpy only (no GL): images, stereo pairs with a known integer shift,
and pairs with a random piecewise-planar disparity field made by warping. Import it in your own
test suite, like ``xarray.testing.strategies``::

    import cv2
    import numpy as np
    from hypothesis import given
    from matcher.testing import shifted_pairs

    @given(shifted_pairs(max_shift=8))
    def test_stereobm_recovers_a_shift(pair):
        bm = cv2.StereoBM_create(numDisparities=16, blockSize=5)
        disp = bm.compute(pair.left, pair.right) / 16.0
        inner = disp[8:-8, 24:-8]
        assert abs(np.median(inner) - pair.shift) <= 0.25

Conventions: a left pixel at ``x`` matches the right pixel at ``x - d`` (``d >= 0``), see
``docs/conventions.md``. Images are (H, W) uint8 unless stated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypothesis import strategies as st

from matcher.patterns import sparse_pattern

__all__ = [
    "windows",
    "grey_images",
    "textured_images",
    "ShiftedPair",
    "shifted_pairs",
    "PlanarPair",
    "piecewise_planar_pairs",
    "monotone_maps",
    "sparse_patterns",
]


def windows(*, min_size: int = 3, max_size: int = 21) -> st.SearchStrategy[int]:
    """Odd window sizes in ``[min_size, max_size]``.
    """
    if min_size < 3 or max_size < min_size:
        raise ValueError(f"need 3 <= min_size <= max_size, got {min_size}, {max_size}")
    lo = min_size + (1 - min_size % 2)
    return st.integers(lo // 2, max_size // 2).map(lambda k: 2 * k + 1)


def _seeds() -> st.SearchStrategy[int]:
    return st.integers(0, 2**32 - 1)


@st.composite
def grey_images(
    draw, *, min_side: int = 4, max_side: int = 32, levels: int = 256
) -> np.ndarray:
    """(H, W) uint8 images of any content (including flat areas and ties).

    ``levels`` limits the number of grey levels, which makes equal intensities (ties) common.
    """
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    rng = np.random.default_rng(draw(_seeds()))
    step = max(1, 256 // levels)
    return (rng.integers(0, levels, size=(h, w)) * step).clip(0, 255).astype(np.uint8)


def _texture(rng: np.random.Generator, h: int, w: int, smooth: float) -> np.ndarray:
    """Random texture with no flat areas: noise, optionally smoothed, stretched to 0..255."""
    img = rng.random((h, w))
    if smooth > 0:
        from scipy.ndimage import gaussian_filter

        img = gaussian_filter(img, smooth, mode="reflect")
    lo, hi = img.min(), img.max()
    return np.round((img - lo) / (hi - lo + 1e-12) * 255.0).astype(np.uint8)


@st.composite
def textured_images(
    draw, *, min_side: int = 16, max_side: int = 48, max_smooth: float = 1.0
) -> np.ndarray:
    """(H, W) uint8 random textures spread over 0..255 (few ties, no flat areas)."""
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    smooth = draw(st.floats(0.0, max_smooth))
    return _texture(np.random.default_rng(draw(_seeds())), h, w, smooth)


@dataclass(frozen=True)
class ShiftedPair:
    """A stereo pair whose true disparity is ``shift`` everywhere (``right = left`` moved left).

    Attributes
    ----------
    left, right : (H, W) uint8 array
    shift : int
        Disparity of every pixel; the left columns ``x < shift`` have no match in the right view.
    """

    left: np.ndarray
    right: np.ndarray
    shift: int


@st.composite
def shifted_pairs(
    draw,
    *,
    max_shift: int = 8,
    min_side: int = 24,
    max_side: int = 48,
    smooth: tuple[float, float] = (0.0, 0.8),
) -> ShiftedPair:
    """Pairs cut from one random texture so that ``left[:, x] == right[:, x - shift]``.

    ``smooth`` is the range of the Gaussian blur (sigma, pixels) of the texture: 0 is white noise;
    about 1.5 and more band-limits it below the Nyquist frequency of a half-resolution image.
    """
    shift = draw(st.integers(0, max_shift))
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(max(min_side, 2 * max_shift + 4), max(max_side, 2 * max_shift + 4)))
    sigma = draw(st.floats(*smooth))
    strip = _texture(np.random.default_rng(draw(_seeds())), h, w + shift, sigma)
    return ShiftedPair(left=strip[:, :w].copy(), right=strip[:, shift : shift + w].copy(), shift=shift)


@dataclass(frozen=True)
class PlanarPair:
    """A pair with a piecewise-planar disparity field, made by warping (no occlusions).

    Attributes
    ----------
    left, right : (H, W) uint8 array
    disparity : (H, W) float64 array
        Exact left disparity: ``left(x, y)`` was sampled from ``right(x - d, y)`` (bilinear).
    labels : (H, W) int array
        Index of the planar piece of each pixel.
    """

    left: np.ndarray
    right: np.ndarray
    disparity: np.ndarray
    labels: np.ndarray


@st.composite
def piecewise_planar_pairs(
    draw,
    *,
    max_disparity: float = 12.0,
    max_pieces: int = 3,
    min_side: int = 24,
    max_side: int = 48,
    integer: bool = False,
) -> PlanarPair:
    """Pairs with 1..``max_pieces`` horizontal bands, each with an affine disparity ``a + b x + c y``.

    The right image is a random texture; the left is the right sampled at ``x - d(x, y)`` with
    bilinear interpolation, so the left disparity is known exactly. ``integer=True`` makes every
    piece fronto-parallel with an integer disparity (no interpolation at all).
    """
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    rng = np.random.default_rng(draw(_seeds()))
    pieces = draw(st.integers(1, max_pieces))
    cuts = np.sort(rng.choice(np.arange(4, h - 3), size=pieces - 1, replace=False)) if pieces > 1 else []
    labels = np.zeros((h, w), dtype=np.int64)
    for k, cut in enumerate(cuts, start=1):
        labels[cut:, :] = k
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    disparity = np.zeros((h, w))
    for k in range(pieces):
        if integer:
            a, b, c = float(rng.integers(0, int(max_disparity) + 1)), 0.0, 0.0
        else:
            a = rng.uniform(0.25 * max_disparity, 0.75 * max_disparity)
            b = rng.uniform(-0.25, 0.25) * max_disparity / w
            c = rng.uniform(-0.25, 0.25) * max_disparity / h
        sel = labels == k
        disparity[sel] = np.clip(a + b * xs[sel] + c * ys[sel], 0.0, max_disparity)
    right = _texture(rng, h, w, draw(st.floats(0.5, 1.0))).astype(np.float64)
    src = np.clip(xs - disparity, 0.0, w - 1.0)
    x0 = np.floor(src).astype(np.int64)
    x1 = np.minimum(x0 + 1, w - 1)
    t = src - x0
    rows = ys.astype(np.int64)
    left = (1 - t) * right[rows, x0] + t * right[rows, x1]
    return PlanarPair(
        left=np.round(left).astype(np.uint8),
        right=right.astype(np.uint8),
        disparity=disparity,
        labels=labels,
    )


@st.composite
def monotone_maps(draw) -> np.ndarray:
    """Strictly increasing lookup tables uint8 -> uint8 restricted to the levels they keep distinct.

    Returns a (256,) int array ``lut`` with ``lut[i] < lut[j]`` for ``i < j`` on 0..255 mapped into
    a wider range 0..1023 (so it is strictly increasing on all 256 levels); apply as
    ``lut[image]``. Kinds: gain/bias, gamma, random increments.
    """
    kind = draw(st.sampled_from(["affine", "gamma", "random"]))
    levels = np.arange(256, dtype=np.float64)
    if kind == "affine":
        gain = draw(st.floats(1.0, 3.9))
        bias = draw(st.floats(0.0, 20.0))
        lut = np.floor(bias + gain * levels)
    elif kind == "gamma":
        gamma = draw(st.floats(0.3, 3.0))
        lut = np.floor(1023.0 * (levels / 255.0) ** gamma) + levels  # + levels keeps it strict
    else:
        rng = np.random.default_rng(draw(_seeds()))
        lut = np.cumsum(rng.integers(1, 4, size=256)).astype(np.float64)
    return lut.astype(np.int64)


def sparse_patterns(*, min_size: int = 3, max_size: int = 21) -> st.SearchStrategy[np.ndarray]:
    """The project's sparse-census offset patterns, ``(n, 2)`` (dy, dx) in bit order."""
    return windows(min_size=min_size, max_size=max_size).map(sparse_pattern)
