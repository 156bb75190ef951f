"""One level of the 2-D Haar wavelet transform (the seed paper's §2.2), and its inverse.

Each 2 x 2 block ``[[a, b], [c, d]]`` of the image (``a`` top-left, ``b`` top-right, ``c``
bottom-left, ``d`` bottom-right) gives one coefficient of each band. With the paper's naming
(first letter: horizontal filter, second letter: vertical filter)::

    LL = s * (a + b + c + d)      horizontal low,  vertical low   (the "approximation")
    LH = s * (a + b - c - d)      horizontal low,  vertical high  (horizontal edges)
    HL = s * (a - b + c - d)      horizontal high, vertical low   (vertical edges)
    HH = s * (a - b - c + d)      horizontal high, vertical high  (diagonal detail)

The scale ``s`` is set by ``norm``:

* ``"orthonormal"`` (default): ``s = 1/2``, the paper's matrix ``(sqrt 2 / 2) [[1, 1], [1, -1]]``
  applied along x and then along y. The transform is orthonormal, so it preserves energy
  (``sum(image**2) == sum of the squares of the four bands``).
* ``"average"``: ``s = 1/4``, the paper's ``(p1 + p2) / 2`` and ``(p1 - p2) / 2`` applied along x
  and then along y. ``LL`` is the mean of the block, so it stays on the image's grey scale.

Odd sizes: an image with an odd number of rows (columns) is padded by replicating its last row
(column) to an even size before the transform; :func:`ihaar2d` crops the pad away again, so the
round trip is exact for every size.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from matcher._validation import check_image

__all__ = ["HAAR_NORMS", "HaarBands", "haar2d", "ihaar2d"]

#: The accepted values of ``norm`` and the scale ``s`` each applies to the 2 x 2 sums.
HAAR_NORMS: dict[str, float] = {"orthonormal": 0.5, "average": 0.25}

Norm = Literal["orthonormal", "average"]


@dataclass(frozen=True)
class HaarBands:
    """The four sub-bands of one Haar level.

    Attributes
    ----------
    ll, lh, hl, hh : (ceil(H / 2), ceil(W / 2)) float64 arrays
        Sub-bands named as in the paper: ``LH`` = horizontal low, vertical high; ``HL`` =
        horizontal high, vertical low (see the module docstring for the formulas).
    shape : (int, int)
        ``(H, W)`` of the transformed image, so :func:`ihaar2d` can crop a replicate pad.
    norm : {"orthonormal", "average"}
        The scaling used (see :data:`HAAR_NORMS`).
    """

    ll: np.ndarray
    lh: np.ndarray
    hl: np.ndarray
    hh: np.ndarray
    shape: tuple[int, int]
    norm: Norm


def _check_norm(norm: object) -> float:
    if not isinstance(norm, str) or norm not in HAAR_NORMS:
        raise ValueError(
            f"norm: expected one of {sorted(HAAR_NORMS)}, got {norm!r}; "
            "use 'orthonormal' (energy preserving) or 'average' (LL = block mean)"
        )
    return HAAR_NORMS[norm]


def _haar(grey: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bands of a validated 2-D image (trusted input), replicate-padded to even sides."""
    h, w = grey.shape
    img = np.asarray(grey, dtype=np.float64)
    if h % 2 or w % 2:
        img = np.pad(img, ((0, h % 2), (0, w % 2)), mode="edge")
    a = img[0::2, 0::2]
    b = img[0::2, 1::2]
    c = img[1::2, 0::2]
    d = img[1::2, 1::2]
    top, bottom = a + b, c + d
    dtop, dbottom = a - b, c - d
    return (
        s * (top + bottom),
        s * (top - bottom),
        s * (dtop + dbottom),
        s * (dtop - dbottom),
    )


def haar2d(image: np.ndarray, *, norm: Norm = "orthonormal") -> HaarBands:
    """One level of the 2-D Haar wavelet transform.

    Parameters
    ----------
    image : (H, W) or (H, W, 3) uint8, integer or float array
        Grey or RGB image (RGB is converted to grey with BT.601 weights). Any size >= 1 x 1;
        odd sides are replicate-padded by one row/column.
    norm : {"orthonormal", "average"}, default "orthonormal"
        ``"orthonormal"``: bands are ``1/2`` times the 2 x 2 sums/differences (energy
        preserving); ``"average"``: ``1/4`` times (``LL`` is the block mean).

    Returns
    -------
    HaarBands
        ``ll, lh, hl, hh`` of shape ``(ceil(H / 2), ceil(W / 2))``, float64.

    References
    ----------
    A. Haar, "Zur Theorie der orthogonalen Funktionensysteme", Math. Ann. 69, 1910.
    Liaw et al., "Improving Census Transform by High-Pass with Haar Wavelet Transform and Edge
    Detection", Sensors 20(9):2537, 2020, §2.2.

    Examples
    --------
    >>> import numpy as np
    >>> bands = haar2d(np.array([[4, 2], [0, 2]], np.uint8), norm="average")
    >>> float(bands.ll[0, 0]), float(bands.lh[0, 0]), float(bands.hl[0, 0]), float(bands.hh[0, 0])
    (2.0, 1.0, 0.0, 1.0)
    """
    s = _check_norm(norm)
    grey = check_image(image, "image")
    ll, lh, hl, hh = _haar(grey, s)
    return HaarBands(ll=ll, lh=lh, hl=hl, hh=hh, shape=(grey.shape[0], grey.shape[1]), norm=norm)


def ihaar2d(bands: HaarBands) -> np.ndarray:
    """Invert :func:`haar2d`: the image (cropped to ``bands.shape``) as float64.

    Parameters
    ----------
    bands : HaarBands
        Output of :func:`haar2d` (possibly with modified coefficients).

    Returns
    -------
    (H, W) float64 array
        ``H, W = bands.shape``. Exact (to rounding) for unmodified bands.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.arange(15, dtype=np.float64).reshape(3, 5)
    >>> bool(np.allclose(ihaar2d(haar2d(img)), img))
    True
    """
    if not isinstance(bands, HaarBands):
        raise TypeError(
            f"bands: expected a HaarBands from haar2d, got {type(bands).__name__}; "
            "call haar2d(image) first"
        )
    s = _check_norm(bands.norm)
    shapes = {np.shape(b) for b in (bands.ll, bands.lh, bands.hl, bands.hh)}
    h, w = bands.shape
    expected = ((h + 1) // 2, (w + 1) // 2)
    if shapes != {expected}:
        raise ValueError(
            f"bands: expected four bands of shape {expected} for an image of shape {(h, w)}, "
            f"got shapes {sorted(shapes)}; keep the bands haar2d returned together"
        )
    ll, lh, hl, hh = (np.asarray(b, dtype=np.float64) for b in (bands.ll, bands.lh, bands.hl, bands.hh))
    # Each band is s * (+-a +-b +-c +-d); the four sign patterns are orthogonal with norm 4,
    # so a = (ll + lh + hl + hh) / (4 s) and so on.
    k = 1.0 / (4.0 * s)
    out = np.empty((2 * expected[0], 2 * expected[1]), dtype=np.float64)
    out[0::2, 0::2] = k * (ll + lh + hl + hh)
    out[0::2, 1::2] = k * (ll + lh - hl - hh)
    out[1::2, 0::2] = k * (ll - lh + hl - hh)
    out[1::2, 1::2] = k * (ll - lh - hl + hh)
    return out[:h, :w]
