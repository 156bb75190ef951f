"""Photometric models applied to a rendered pair: blur, gamma, gain/bias mismatch, noise, JPEG.

The models act on the images only (ground truth is unchanged) and in a fixed order:

1. Gaussian blur of both images (``blur_sigma`` pixels, reflected borders);
2. gamma ``255 * (x / 255) ** gamma`` on both images (blurred: of ``x`` rounded to 1/256);
3. right image only: ``x * gain + bias`` (the left/right mismatch);
4. independent Gaussian noise of standard deviation ``noise_sigma`` grey levels on every
   pixel and channel of each image (left drawn first, then right);
5. rounding (half to even) and clipping to uint8;
6. a JPEG round trip at ``jpeg_quality`` (1..100; 0 = off) of each image.

All randomness comes from the ``rng`` passed in, so a sample is reproducible from its seed.
The power of step 2 is the algorithm of glibc's ``powf`` on every CPU
(:mod:`synth.appearance._powf`), so the same seed gives the same bytes on AVX2 and AVX-512
machines alike. A blurred image's float32 values are first rounded to the nearest 1/256 of a
grey level (halves up; :func:`_grid16`) and their powers read from a table of those 65281
levels (:func:`_gamma_table16`), built once per gamma: the powers of ~1.5 M values per 960x540
view were the dearest model (~7.8 ms a view on an AVX2 CPU; the table and lookup ~2.5 ms with
the noise). The rounding moves a blurred value by at most 1/512 of a grey level: with noise
~0.1 % of the output grey levels differ by one from the power of the unrounded value, none by
more (measured on 960x540 ``flying`` renders, gammas 0.8-1.25).

The noise is drawn by inverse-CDF lookup (:func:`gaussian_noise`): every value takes 16 raw
bits of ``rng``'s bit generator and reads one of 65536 equiprobable quantiles of the standard
normal (rescaled to unit variance). Its tails stop at +-4.3 sigma, where a true Gaussian
leaves 1.5e-5 of its mass; after rounding to grey levels the difference is invisible. It costs
~1.5 ms per 640 x 480 RGB image instead of ~10 ms for ``Generator.standard_normal``, and, since
only raw bit-generator output is used, the bytes do not change with the numpy version.

With noise, steps 2 (a gamma: a 256-entry table, or the 65281-entry one after a blur), 3, 4
and 5 of each image run in one pass (:func:`_noisy_kernel`, :func:`_noisy_lut_kernel`): per
value ``rint(fma(x, gain, noise + bias))`` in float32, saturated to uint8, the arithmetic of
OpenCV's ``addWeighted(x, gain, noise, 1, bias, dtype=CV_8U)`` (its float32 multiply-add,
round half to even) that this pass replaces, without the noise and gamma arrays in memory
(tests/synth/test_photometric_kernel.py compares the two).
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass
from typing import Any, Mapping, NamedTuple

import cv2
import numpy as np
from numba import njit

from stereoforge.errors import ParameterTypeError
from stereoforge.validation import check_int, check_keys, check_real, check_type, describe, fail
from synth.appearance._powf import fma, powf

__all__ = ["PhotometricParams", "PhotometricPair", "apply_photometric", "gaussian_noise"]

#: Random bits per noise value: the quantile table has ``2**NOISE_BITS`` entries.
_NOISE_BITS = 16


@dataclass(frozen=True)
class PhotometricParams:
    """Parameters of the photometric models (defaults are the identity).

    Parameters
    ----------
    noise_sigma : float
        Standard deviation of additive Gaussian noise, grey levels, in [0, 64].
    gain : float
        Gain of the right image relative to the left, in (0, 4].
    bias : float
        Bias of the right image relative to the left, grey levels, in [-128, 128].
    gamma : float
        Gamma of both images, in [0.1, 10].
    blur_sigma : float
        Gaussian blur standard deviation, pixels, in [0, 16].
    jpeg_quality : int
        JPEG quality 1..100 of a round trip of both images; 0 = no JPEG.

    Examples
    --------
    >>> PhotometricParams().is_identity()
    True
    >>> PhotometricParams(gain=0.0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: PhotometricParams.gain: expected a finite number in (0, 4], got 0.0
    """

    noise_sigma: float = 0.0
    gain: float = 1.0
    bias: float = 0.0
    gamma: float = 1.0
    blur_sigma: float = 0.0
    jpeg_quality: int = 0

    def __post_init__(self) -> None:
        bounds = {"noise_sigma": (0, 64, False), "gain": (0, 4, True), "bias": (-128, 128, False),
                  "gamma": (0.1, 10, False), "blur_sigma": (0, 16, False)}
        for name, (lo, hi, lo_open) in bounds.items():
            object.__setattr__(self, name, check_real(getattr(self, name),
                                                      f"PhotometricParams.{name}", lo=lo, hi=hi,
                                                      lo_open=lo_open))
        object.__setattr__(self, "jpeg_quality", check_int(
            self.jpeg_quality, "PhotometricParams.jpeg_quality", lo=0, hi=100,
            fix="1..100 is the quality of a JPEG round trip, 0 turns it off"))

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> PhotometricParams:
        """Build from a mapping of field names (unknown names raise ``ValueError``)."""
        check_keys(values, "PhotometricParams", cls.__dataclass_fields__)
        return cls(**dict(values))

    def to_dict(self) -> dict[str, Any]:
        """Plain dict of the fields."""
        return asdict(self)

    def is_identity(self) -> bool:
        """True if :func:`apply_photometric` returns its input unchanged."""
        return self == PhotometricParams()


class PhotometricPair(NamedTuple):
    """The degraded images: ``left``, ``right``, (H, W, 3) or (H, W) uint8 arrays."""

    left: np.ndarray
    right: np.ndarray


@functools.cache
def _normal_quantiles() -> np.ndarray:
    """The ``2**16`` mid-quantiles ``Phi^-1((k + 1/2) / 2**16)``, scaled to unit variance."""
    from scipy.special import ndtri

    n = 1 << _NOISE_BITS
    q = ndtri((np.arange(n, dtype=np.float64) + 0.5) / n)
    q /= math.sqrt(float(np.mean(q * q)))
    q.setflags(write=False)
    return q


def gaussian_noise(shape: tuple[int, ...], sigma: float, *,
                   rng: np.random.Generator | int | None) -> np.ndarray:
    """Independent zero-mean Gaussian values of standard deviation ``sigma`` (float32).

    Inverse-CDF sampling at 16-bit resolution: each value reads one of the 65536 equiprobable
    quantiles of the standard normal (mid-points, rescaled to unit variance; the largest is
    4.3), indexed by 16 raw bits of ``rng.bit_generator`` (little-endian 16-bit words of its
    64-bit outputs, in order). About 6x faster than ``Generator.standard_normal``, and the
    values depend only on the bit generator's stream, not on the numpy version.

    Parameters
    ----------
    shape : tuple of int
    sigma : float
        Standard deviation, ``>= 0``.
    rng : numpy.random.Generator, int or None
        ``np.random.default_rng(rng)``; advanced by ``ceil(size / 4)`` 64-bit outputs.

    Returns
    -------
    ndarray of float32, of the given shape

    Examples
    --------
    >>> x = gaussian_noise((200, 200), 2.0, rng=0)
    >>> x.dtype.name, round(float(x.std()), 1), abs(float(x.mean())) < 0.05
    ('float32', 2.0, True)
    >>> bool((gaussian_noise((3,), 1.0, rng=5) == gaussian_noise((3,), 1.0, rng=5)).all())
    True
    """
    check_real(sigma, "sigma", lo=0)
    rng = np.random.default_rng(rng)
    size = math.prod(shape)
    out = np.empty(size, np.float32)
    # = table.take(index), without its int64 copy of the index
    _gather(_noise_table(sigma), _noise_words(size, rng), out)
    return out.reshape(shape)


@njit(cache=True, nogil=True)
def _gather(table: np.ndarray, index: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    """``out[i] = table[index[i]]``; ``index`` (uint16) is always within ``table`` (2**16)."""
    for i in range(index.shape[0]):
        out[i] = table[index[i]]


@njit(cache=True, nogil=True, inline="always")
def _noisy(x: np.float32, noise: np.float32, gain: np.float32, bias: np.float32
           ) -> np.uint8:  # pragma: no cover - compiled
    v = np.rint(fma(x, gain, noise + bias))
    return np.uint8(min(max(v, np.float32(0.0)), np.float32(255.0)))


@njit(cache=True, nogil=True)
def _noisy_kernel(image: np.ndarray, table: np.ndarray, index: np.ndarray, gain: np.float32,
                  bias: np.float32, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[i] = uint8(rint(fma(image[i], gain, table[index[i]] + bias)))`` saturated; flat
    arrays, float32 ``image``, ``index`` uint16 into ``table`` (2**16 float32)."""
    for i in range(out.shape[0]):
        out[i] = _noisy(image[i], table[index[i]], gain, bias)


@njit(cache=True, nogil=True)
def _noisy_lut_kernel(image: np.ndarray, lut: np.ndarray, table: np.ndarray, index: np.ndarray,
                      gain: np.float32, bias: np.float32,
                      out: np.ndarray) -> None:  # pragma: no cover - compiled
    """:func:`_noisy_kernel` of ``lut[image[i]]``: uint8 ``image`` and a 256-entry float32
    ``lut``, or uint16 ``image`` (:func:`_grid16`) and a 65281-entry one."""
    for i in range(out.shape[0]):
        out[i] = _noisy(lut[image[i]], table[index[i]], gain, bias)


#: Levels of the grid a blurred value is rounded to before its gamma: 1/256 of a grey level.
_GRID = 256
_GRID_TOP = 255 * _GRID  # 65280: grey level 255


@njit(cache=True, nogil=True)
def _grid16_kernel(image: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """``out[i] = floor(image[i] * 256 + 0.5)`` clipped to [0, 65280]; flat arrays, float32 in
    (``image[i] * 256 + 0.5`` is exact in float32 up to 2**23), uint16 out."""
    for i in range(out.shape[0]):
        q = image[i] * np.float32(_GRID) + np.float32(0.5)
        q = min(max(q, np.float32(0.0)), np.float32(_GRID_TOP))
        out[i] = np.uint16(np.int32(q))  # truncation: floor, q >= 0


def _grid16(image: np.ndarray) -> np.ndarray:
    """A blurred float32 image on the grid of 1/256 grey levels: uint16 ``round(256 * x)``
    (halves up), clipped to 0..65280 (grey levels 0..255)."""
    out = np.empty(image.shape, np.uint16)
    _grid16_kernel(np.ascontiguousarray(image, dtype=np.float32).reshape(-1), out.reshape(-1))
    return out


@functools.lru_cache(maxsize=8)
def _gamma_table16(gamma: float) -> np.ndarray:
    """The gamma of the 65281 grid levels ``k / 256``: ``_gamma`` of their float32 values (exact:
    ``k / 256`` is), read-only; cached (the right-view variants of a sample share it)."""
    levels = np.arange(_GRID_TOP + 1, dtype=np.float32) * np.float32(1.0 / _GRID)
    table = _gamma(levels, gamma)
    table.setflags(write=False)
    return table


def _noise_words(size: int, rng: np.random.Generator) -> np.ndarray:
    """``size`` uint16 words of ``rng``'s bit generator (those of :func:`gaussian_noise`)."""
    words = rng.bit_generator.random_raw((size + 3) // 4)
    return words.astype("<u8", copy=False).view("<u2")[:size]


def _noise_table(sigma: float) -> np.ndarray:
    return (_normal_quantiles() * float(sigma)).astype(np.float32)


def _noisy_uint8(image: np.ndarray, lut: np.ndarray | None, gain: float, bias: float,
                 sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``round(lut[image] * gain + bias + gaussian_noise(image.shape, sigma, rng=rng))`` clipped
    to uint8 (``lut=None``: ``image`` itself, float32) in one pass; draws what
    :func:`gaussian_noise` draws."""
    out = np.empty(image.shape, np.uint8)
    flat = np.ascontiguousarray(image).reshape(-1)
    args = (_noise_table(sigma), _noise_words(flat.size, rng), np.float32(gain),
            np.float32(bias), out.reshape(-1))
    if lut is None:
        _noisy_kernel(flat, *args)
    else:
        _noisy_lut_kernel(flat, lut, *args)
    return out


def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    k = 2 * int(math.ceil(3.0 * sigma)) + 1
    return cv2.GaussianBlur(img, (k, k), sigmaX=sigma, sigmaY=sigma,
                            borderType=cv2.BORDER_REFLECT_101)


def _jpeg(img: np.ndarray, quality: int) -> np.ndarray:
    """The JPEG round trip of an RGB or grey image (OpenCV's codec, which wants BGR: the
    channels are swapped by ``cvtColor``, ~3x faster than numpy's copies of reversed views)."""
    colour = img.ndim == 3
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(img, cv2.COLOR_RGB2BGR) if colour else img,
                           [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:  # pragma: no cover - OpenCV always encodes uint8 images
        raise RuntimeError("OpenCV could not encode the JPEG round trip")
    if not colour:
        return cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)
    return cv2.cvtColor(cv2.imdecode(buf, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)


def _gamma(img: np.ndarray, gamma: float) -> np.ndarray:
    """``255 * (img / 255) ** gamma`` of a float32 array, in float32, as a new array: the float32
    products of ``np.multiply`` and the power of glibc's ``powf`` on every CPU
    (:func:`synth.appearance._powf.powf`; ``np.power`` takes Intel's SVML on AVX-512 CPUs, whose
    last bits differ, and is ~1.4x slower on AVX2 ones)."""
    return powf(img, gamma, pre=1.0 / 255.0, post=255.0)


def _to_uint8(img: np.ndarray, gain: float, bias: float) -> np.ndarray:
    """``round(img * gain + bias)`` clipped to uint8 (without noise: see :func:`_noisy_uint8`)."""
    if img.dtype == np.uint8 and gain == 1.0 and bias == 0.0:
        return img.copy()
    out = img.astype(np.float32)  # a copy: the caller's array is never modified
    if gain != 1.0 or bias != 0.0:
        np.multiply(out, np.float32(gain), out=out)
        np.add(out, np.float32(bias), out=out)
    np.rint(out, out=out)
    np.clip(out, 0, 255, out=out)
    return out.astype(np.uint8)


def apply_photometric(left: np.ndarray, right: np.ndarray, params: PhotometricParams, *,
                      rng: np.random.Generator | int | None) -> PhotometricPair:
    """Apply the photometric models to a pair (see the module docstring for the order).

    Parameters
    ----------
    left, right : (H, W, 3) or (H, W) uint8 array
        Rendered images of one shape.
    params : PhotometricParams
    rng : numpy.random.Generator, int or None
        Source of the noise (``np.random.default_rng(rng)``; see :func:`gaussian_noise`).

    Returns
    -------
    PhotometricPair
        New uint8 arrays of the input shape (the inputs themselves when ``params`` is the
        identity).

    Examples
    --------
    >>> img = np.full((4, 4, 3), 100, np.uint8)
    >>> out = apply_photometric(img, img, PhotometricParams(gain=1.1, bias=-5.0), rng=0)
    >>> int(out.left[0, 0, 0]), int(out.right[0, 0, 0])
    (100, 105)
    >>> noisy = apply_photometric(img, img, PhotometricParams(noise_sigma=2.0), rng=1)
    >>> bool((noisy.left != img).any()), noisy.left.dtype.name
    (True, 'uint8')
    """
    check_type(params, "params", PhotometricParams)
    for name, img in (("left", left), ("right", right)):
        if not isinstance(img, np.ndarray) or img.dtype != np.uint8 or img.ndim not in (2, 3) \
                or (img.ndim == 3 and img.shape[2] != 3):
            raise fail(name, "an (H, W) or (H, W, 3) uint8 image", describe(img),
                       fix="convert with .astype(np.uint8); drop an alpha channel with [..., :3]",
                       error=ParameterTypeError)
    if left.shape != right.shape:
        raise fail("left and right", "one shape", f"{left.shape} and {right.shape}",
                   fix="render or crop both views to one size")
    if params.is_identity():
        return PhotometricPair(left, right)
    rng = np.random.default_rng(rng)
    images = [left, right]  # uint8 until a model needs floats
    lut = None  # the gamma as a table: one entry per grey level, or per 1/256 when blurred
    if params.blur_sigma > 0:
        images = [_blur(img.astype(np.float32), params.blur_sigma) for img in images]
    if params.gamma != 1.0:
        if params.blur_sigma > 0:  # uint16 levels of 1/256 grey level
            images = [_grid16(img) for img in images]
            lut = _gamma_table16(params.gamma)
        else:
            lut = _gamma(np.arange(256, dtype=np.float32), params.gamma)
    gains = ((1.0, 0.0), (params.gain, params.bias))
    if params.noise_sigma > 0:  # left's noise drawn first, then right's
        if lut is None and images[0].dtype == np.uint8:
            lut = np.arange(256, dtype=np.float32)  # uint8 -> float32, exactly
        out = [_noisy_uint8(img, lut, g, b, params.noise_sigma, rng)
               for img, (g, b) in zip(images, gains)]
    else:
        if lut is not None:  # float32 values: cv2.LUT reads uint8 indices only
            images = [cv2.LUT(img, lut) if img.dtype == np.uint8 else lut[img]
                      for img in images]
        out = [_to_uint8(img, g, b) for img, (g, b) in zip(images, gains)]
    if params.jpeg_quality > 0:
        out = [_jpeg(img, params.jpeg_quality) for img in out]
    return PhotometricPair(out[0], out[1])
