"""Photometric models applied to a rendered pair: blur, gamma, gain/bias mismatch, noise, JPEG.

The models act on the images only (ground truth is unchanged) and in a fixed order:

1. Gaussian blur of both images (``blur_sigma`` pixels, reflected borders);
2. gamma ``255 * (x / 255) ** gamma`` on both images;
3. right image only: ``x * gain + bias`` (the left/right mismatch);
4. independent Gaussian noise of standard deviation ``noise_sigma`` grey levels on every
   pixel and channel of each image (left drawn first, then right);
5. rounding and clipping to uint8;
6. a JPEG round trip at ``jpeg_quality`` (1..100; 0 = off) of each image.

All randomness comes from the ``rng`` passed in, so a sample is reproducible from its seed.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any, Mapping, NamedTuple

import cv2
import numpy as np

__all__ = ["PhotometricParams", "PhotometricPair", "apply_photometric"]


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
    ValueError: PhotometricParams.gain must be in (0, 4], got 0.0
    """

    noise_sigma: float = 0.0
    gain: float = 1.0
    bias: float = 0.0
    gamma: float = 1.0
    blur_sigma: float = 0.0
    jpeg_quality: int = 0

    def __post_init__(self) -> None:
        bounds = {"noise_sigma": (0.0, 64.0, False), "gain": (0.0, 4.0, True),
                  "bias": (-128.0, 128.0, False), "gamma": (0.1, 10.0, False),
                  "blur_sigma": (0.0, 16.0, False)}
        for name, (lo, hi, lo_open) in bounds.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.integer,
                                                                  np.floating)):
                raise TypeError(f"PhotometricParams.{name} must be a number, got {value!r}")
            value = float(value)
            ok = math.isfinite(value) and (value > lo if lo_open else value >= lo) and value <= hi
            if not ok:
                interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
                raise ValueError(f"PhotometricParams.{name} must be in {interval}, got {value!r}")
            object.__setattr__(self, name, value)
        q = self.jpeg_quality
        if isinstance(q, bool) or not isinstance(q, (int, np.integer)) or not 0 <= q <= 100:
            raise ValueError(f"PhotometricParams.jpeg_quality must be an int in [0, 100] "
                             f"(0 = off), got {q!r}")
        object.__setattr__(self, "jpeg_quality", int(q))

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> PhotometricParams:
        """Build from a mapping of field names (unknown names raise ``ValueError``)."""
        unknown = sorted(set(values) - set(cls.__dataclass_fields__))
        if unknown:
            raise ValueError(f"unknown photometric parameters {unknown}; allowed: "
                             f"{list(cls.__dataclass_fields__)}")
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


def _blur(img: np.ndarray, sigma: float) -> np.ndarray:
    k = 2 * int(math.ceil(3.0 * sigma)) + 1
    return cv2.GaussianBlur(img, (k, k), sigmaX=sigma, sigmaY=sigma,
                            borderType=cv2.BORDER_REFLECT_101)


def _jpeg(img: np.ndarray, quality: int) -> np.ndarray:
    colour = img.ndim == 3
    ok, buf = cv2.imencode(".jpg", img[..., ::-1] if colour else img,
                           [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:  # pragma: no cover - OpenCV always encodes uint8 images
        raise RuntimeError("OpenCV could not encode the JPEG round trip")
    out = cv2.imdecode(buf, cv2.IMREAD_COLOR if colour else cv2.IMREAD_GRAYSCALE)
    return np.ascontiguousarray(out[..., ::-1] if colour else out)


def apply_photometric(left: np.ndarray, right: np.ndarray, params: PhotometricParams, *,
                      rng: np.random.Generator | int | None) -> PhotometricPair:
    """Apply the photometric models to a pair (see the module docstring for the order).

    Parameters
    ----------
    left, right : (H, W, 3) or (H, W) uint8 array
        Rendered images of one shape.
    params : PhotometricParams
    rng : numpy.random.Generator, int or None
        Source of the noise (``np.random.default_rng(rng)``).

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
    if not isinstance(params, PhotometricParams):
        raise TypeError(f"params must be a PhotometricParams, got {type(params).__name__}")
    for name, img in (("left", left), ("right", right)):
        if not isinstance(img, np.ndarray) or img.dtype != np.uint8 or img.ndim not in (2, 3):
            got = f"{img.dtype} {img.shape}" if isinstance(img, np.ndarray) else type(img).__name__
            raise TypeError(f"{name} must be an (H, W[, 3]) uint8 image, got {got}")
    if left.shape != right.shape:
        raise ValueError(f"left and right must have one shape, got {left.shape} and "
                         f"{right.shape}")
    if params.is_identity():
        return PhotometricPair(left, right)
    rng = np.random.default_rng(rng)
    images = [left.astype(np.float32), right.astype(np.float32)]
    if params.blur_sigma > 0:
        images = [_blur(img, params.blur_sigma) for img in images]
    if params.gamma != 1.0:
        for img in images:
            np.multiply(img, np.float32(1.0 / 255.0), out=img)
            np.power(img, np.float32(params.gamma), out=img)
            np.multiply(img, np.float32(255.0), out=img)
    if params.gain != 1.0 or params.bias != 0.0:
        np.multiply(images[1], np.float32(params.gain), out=images[1])
        np.add(images[1], np.float32(params.bias), out=images[1])
    if params.noise_sigma > 0:
        for img in images:
            noise = rng.standard_normal(img.shape, dtype=np.float32)
            noise *= np.float32(params.noise_sigma)
            img += noise
    out = []
    for img in images:
        np.rint(img, out=img)
        np.clip(img, 0, 255, out=img)
        out.append(img.astype(np.uint8))
    if params.jpeg_quality > 0:
        out = [_jpeg(img, params.jpeg_quality) for img in out]
    return PhotometricPair(out[0], out[1])
