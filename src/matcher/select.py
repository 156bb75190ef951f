"""Disparity selection from a cost volume: winner-takes-all, left-right check, subpixel.

Rules (the fused kernel of :func:`matcher.match` follows them bit for bit):

* **WTA**: the smallest cost over the candidates ``d`` with ``x - d >= 0``; ties go to the
  smallest ``d``.
* **Left-right check**: the right view's disparity ``d_R(x_r)`` is the WTA over the same costs
  seen from the right pixel, ``cost[y, d, x_r + d]`` for ``x_r + d < W`` (ties -> smallest ``d``).
  A left pixel fails, and gets ``inf``, when ``|d_L(x) - d_R(x - d_L(x))| > tolerance``.
* **Subpixel**: a parabola through the costs at ``d - 1, d, d + 1`` moves ``d`` by
  ``(c[d-1] - c[d+1]) / (2 (c[d-1] - 2 c[d] + c[d+1]))`` (float64, then float32). It is applied
  only where both neighbours are candidates (``1 <= d <= D - 2`` and ``x - d - 1 >= 0``) and the
  curvature is positive; elsewhere ``d`` stays an integer.

:func:`winner_takes_all` runs one parallel numba kernel (:mod:`matcher._kernels.select`), a row of
the volume per work item, without copying the volume.
"""

from __future__ import annotations

import numba
import numpy as np

from matcher._kernels import wta_kernel

__all__ = ["winner_takes_all"]


def _check_cost(cost: object) -> np.ndarray:
    if (
        not isinstance(cost, np.ndarray)
        or cost.ndim != 3
        or cost.dtype not in (np.dtype(np.uint16), np.dtype(np.uint32))
    ):
        got = (
            f"array of shape {cost.shape} and dtype {cost.dtype}"
            if isinstance(cost, np.ndarray)
            else type(cost).__name__
        )
        raise TypeError(
            f"cost: expected an (H, D, W) uint16 or uint32 cost volume, got {got}; "
            "use matcher.cost.cost_volume (or aggregate_cost)"
        )
    return cost


def winner_takes_all(
    cost: np.ndarray,
    *,
    lr_check: bool = False,
    lr_tolerance: int = 1,
    subpixel: bool = False,
) -> np.ndarray:
    """Disparity of each left pixel by winner-takes-all over a cost volume.

    Parameters
    ----------
    cost : (H, D, W) uint16 or uint32 array
        From :func:`matcher.cost.cost_volume` or :func:`matcher.cost.aggregate_cost`; entries
        with ``x - d < 0`` hold the dtype's maximum (the sentinel).
    lr_check : bool, default False
        Mark pixels that fail the left-right consistency check as ``inf``.
    lr_tolerance : int, default 1
        Largest accepted ``|d_L - d_R|`` in pixels.
    subpixel : bool, default False
        Refine with a parabola through the neighbouring costs.

    Returns
    -------
    (H, W) float32 array
        Disparity in pixels; ``inf`` where the LR check fails.

    Examples
    --------
    >>> import numpy as np
    >>> cost = np.full((1, 3, 2), 65535, np.uint16)  # (H, D, W); x - d < 0 keeps the sentinel
    >>> cost[0, 0, :] = [5, 3]
    >>> cost[0, 1, 1] = 3  # x = 1: d = 0 and d = 1 tie -> d = 0
    >>> winner_takes_all(cost).tolist()
    [[0.0, 0.0]]
    """
    cost = _check_cost(cost)
    if isinstance(lr_tolerance, bool) or not isinstance(lr_tolerance, (int, np.integer)):
        raise TypeError(f"lr_tolerance: expected an integer >= 0, got {lr_tolerance!r}")
    if lr_tolerance < 0:
        raise ValueError(f"lr_tolerance: expected an integer >= 0, got {lr_tolerance}")
    n_rows, n_disp, width = cost.shape
    if n_disp == 0:
        raise ValueError(f"cost: expected at least one disparity (D >= 1), got shape {cost.shape}")
    out = np.empty((n_rows, width), dtype=np.float32)
    bad = np.zeros(1, np.int64)
    lr_tol = int(min(lr_tolerance, n_disp)) if lr_check else -1  # |d_L - d_R| < D
    wta_kernel(
        np.ascontiguousarray(cost), lr_tol, bool(subpixel), numba.get_num_threads(),
        np.zeros(1, np.int64), out, bad,
    )
    if bad[0]:
        raise IndexError(
            "cost: a left disparity d > x + W has no right partner; entries with x - d < 0 must "
            "hold the sentinel (the dtype's maximum)"
        )
    return out
