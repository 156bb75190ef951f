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
"""

from __future__ import annotations

import numpy as np

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


def _right_costs(cost: np.ndarray) -> np.ndarray:
    """The cost volume seen from the right view: ``out[y, d, xr] = cost[y, d, xr + d]``."""
    sentinel = np.iinfo(cost.dtype).max
    out = np.full(cost.shape, sentinel, dtype=cost.dtype)
    width = cost.shape[2]
    for d in range(min(cost.shape[1], width)):
        out[:, d, : width - d] = cost[:, d, d:]
    return out


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
    d_left = np.argmin(cost, axis=1)  # first minimum: ties -> smallest d
    out = d_left.astype(np.float64)
    if subpixel:
        ys, xs = np.indices(d_left.shape)
        ok = (d_left >= 1) & (d_left <= n_disp - 2) & (xs - d_left - 1 >= 0)
        dm = np.clip(d_left - 1, 0, n_disp - 1)
        dp = np.clip(d_left + 1, 0, n_disp - 1)
        cm = cost[ys, dm, xs].astype(np.float64)
        cp = cost[ys, dp, xs].astype(np.float64)
        c0 = cost[ys, d_left, xs].astype(np.float64)
        den = cm - 2.0 * c0 + cp
        ok &= den > 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            offset = (cm - cp) / (2.0 * den)
        out = np.where(ok, out + offset, out)
    if lr_check:
        d_right = np.argmin(_right_costs(cost), axis=1)
        xs = np.arange(width)[None, :]
        partner = np.take_along_axis(d_right, xs - d_left, axis=1)
        out[np.abs(d_left - partner) > lr_tolerance] = np.inf
    return out.astype(np.float32)
