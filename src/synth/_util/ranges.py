"""The range of disparity maps' finite values in one compiled pass (``calib.txt``'s bounds, a
sample's ``disp_min``/``disp_max``)."""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["finite_range"]


@njit(cache=True, nogil=True)
def _finite_range(values: np.ndarray, lo: float, hi: float
                  ) -> tuple[float, float]:  # pragma: no cover - compiled
    for v in values:
        if np.isfinite(v):
            lo = min(lo, np.float64(v))
            hi = max(hi, np.float64(v))
    return lo, hi


def finite_range(*maps: np.ndarray) -> tuple[float, float]:
    """``(min, max)`` of the finite values of all ``maps`` (float32 or float64), ``(inf, -inf)``
    if there is none: what numpy's ``min``/``max`` with ``where=np.isfinite(d)`` give (minima
    and maxima are exact), in one pass instead of their three (~1.5 ms per 960x540 pair).

    Examples
    --------
    >>> finite_range(np.array([[2.5, np.inf], [np.nan, -1.0]], np.float32))
    (-1.0, 2.5)
    >>> finite_range(np.full(3, np.inf))
    (inf, -inf)
    """
    lo, hi = np.inf, -np.inf
    for d in maps:
        lo, hi = _finite_range(np.ascontiguousarray(d).reshape(-1), lo, hi)
    return float(lo), float(hi)
