"""The learned matcher's cost volume, aggregation and selection in torch, on the features' device.

The same steps, and the same numbers, as the numba path of :func:`matcher.learned.match_learned`
(:func:`matcher.learned.cost.feature_cost`, :func:`matcher.cost.aggregate_cost`,
:func:`matcher.select.winner_takes_all`), written as whole-tensor operations so that they run
where the features are (a GPU) without a trip through the host:

- **cost**: ``round((1 - <f_L, f_R>) * COST_SCALE)``; the dot product is summed channel by
  channel in float32 (one multiply, then one add, per channel, as the numba kernel does it), so
  every quantised cost is the kernel's, bit for bit; :data:`COST_SENTINEL` where ``x - d < 0``;
- **box aggregation**: exact integer running sums (int64) over the valid columns ``x >= d`` with
  the edge replicated, wrapped to uint32 as the numba kernel's arithmetic wraps;
- **selection**: the first minimum over ``d`` (ties to the smallest ``d``) from the left and the
  right view, the left-right check, and the parabola in float64 with the kernel's operations in
  its order, then float32.

So the integer disparities and the invalid mask are the numba path's exactly, and the sub-pixel
values agree to the last float32 bit wherever float64 division is correctly rounded (both
IEEE 754). :func:`volume_disparity` builds the volume in chunks of rows, each with the box's halo
of rows, of at most :data:`CHUNK_BYTES` of tensors at a time.

On a CUDA device the cost comes from one Triton kernel instead
(:mod:`matcher.learned._triton_cost`: the same float32 operations in the same order, the
accumulator in registers instead of two whole-volume passes per channel) when ``triton`` can be
imported; without it, from the torch operations above.
"""

from __future__ import annotations

from collections.abc import Callable

import torch

__all__ = ["BYTES_PER_ENTRY", "CHUNK_BYTES", "volume_disparity"]

#: Most bytes of working tensors per chunk, by device type (others use the CPU's).
CHUNK_BYTES = {"cpu": 64 << 20, "cuda": 4 << 30}
#: Bytes of working tensors per volume entry at the peak (the box sums' int64 copies), rounded up.
BYTES_PER_ENTRY = 64
_COST_SENTINEL = 65535
_AGG_SENTINEL = 0xFFFFFFFF
_TOP = 65534.0
_WRAP = 0xFFFFFFFF


def _cost(fl: torch.Tensor, fr: torch.Tensor, n_disp: int, scale: float) -> torch.Tensor:
    """(h, D, W) int32 quantised costs of (h, C, W) float32 features."""
    h, c, w = fr.shape
    # right features shifted by every d at once: view[y, ch, k, x] = fr[y, ch, x + k - (D - 1)]
    # (zeros left of the image), so k = D - 1 - d
    padded = torch.nn.functional.pad(fr, (n_disp - 1, 0)).contiguous()
    sy, sc, sx = padded.stride()
    shifted = padded.as_strided((h, c, n_disp, w), (sy, sc, sx, sx))
    acc = torch.zeros((h, n_disp, w), dtype=torch.float32, device=fl.device)
    prod = torch.empty_like(acc)
    for ch in range(c):  # float32, one product and one sum per channel: the kernel's rounding
        torch.mul(fl[:, ch, None, :], shifted[:, ch], out=prod)
        acc.add_(prod)
    acc = acc.flip(1)
    val = (1.0 - acc).mul_(scale).add_(0.5).clamp_(0.0, _TOP)
    cost = val.to(torch.int32)  # truncation of a value >= 0: the kernel's uint16 cast
    cost.masked_fill_(_invalid(n_disp, w, fl.device), _COST_SENTINEL)
    return cost


def _cost_for(device: torch.device) -> Callable[..., torch.Tensor]:
    """The cost function for features on ``device``: the Triton kernel on a CUDA device where
    ``triton`` imports, else :func:`_cost`."""
    if device.type != "cuda":
        return _cost
    try:
        from matcher.learned._triton_cost import cost
    except ImportError:  # a torch build without triton: the same numbers, more memory traffic
        return _cost
    return cost


def _invalid(n_disp: int, w: int, device: torch.device) -> torch.Tensor:
    """(D, W) bool: ``x - d < 0``."""
    d = torch.arange(n_disp, device=device)[:, None]
    x = torch.arange(w, device=device)[None, :]
    return x < d


def _box(values: torch.Tensor, half: int, dim: int) -> torch.Tensor:
    """Sums of ``2 half + 1`` consecutive entries along ``dim`` of an edge-padded int64 tensor
    (``2 half`` entries longer than the result)."""
    cs = torch.cumsum(values, dim=dim)
    n = values.shape[dim] - 2 * half
    head = cs.narrow(dim, 2 * half, n)
    zero = torch.zeros_like(cs.narrow(dim, 0, 1))
    tail = torch.cat([zero, cs.narrow(dim, 0, n - 1)], dim=dim)
    return head - tail


def _aggregate(cost: torch.Tensor, size: int) -> torch.Tensor:
    """(h, D, W) int64 box sums of side ``size`` over the valid columns, edge replicated;
    the uint32 sentinel where ``x - d < 0``."""
    h, n_disp, w = cost.shape
    half = size // 2
    dev = cost.device
    # columns < d read column d: fill them, then a plain edge-replicated box does the rest
    first = torch.arange(w, device=dev)[None, :].maximum(torch.arange(n_disp, device=dev)[:, None])
    filled = torch.gather(cost.to(torch.int64), 2, first.expand(h, n_disp, w))
    rows = torch.arange(-half, h + half, device=dev).clamp_(0, h - 1)
    cols = torch.arange(-half, w + half, device=dev).clamp_(0, w - 1)
    padded = filled.index_select(0, rows).index_select(2, cols)
    out = _box(_box(padded, half, 0), half, 2).bitwise_and_(_WRAP)
    out.masked_fill_(_invalid(n_disp, w, dev), _AGG_SENTINEL)
    return out


def _first_min(cost: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The smallest value over dim 1 and its first index (ties to the smallest)."""
    best = cost.amin(dim=1)
    index = torch.arange(cost.shape[1], device=cost.device)[None, :, None]
    first = torch.where(cost == best[:, None], index, cost.shape[1]).amin(dim=1)
    return best, first


def _select(cost: torch.Tensor, lr_tol: int, subpixel: bool) -> torch.Tensor:
    """(h, W) float32 disparities of an (h, D, W) int volume (the numba wta kernel's rules)."""
    h, n_disp, w = cost.shape
    dev = cost.device
    best, d_left = _first_min(cost)
    val = d_left.to(torch.float64)
    x = torch.arange(w, device=dev)[None, :]
    if subpixel:
        ok = (d_left >= 1) & (d_left <= n_disp - 2) & (x - d_left - 1 >= 0)
        cm = torch.gather(cost, 1, (d_left - 1).clamp(min=0)[:, None])[:, 0].to(torch.float64)
        cp = torch.gather(cost, 1, (d_left + 1).clamp(max=n_disp - 1)[:, None])[:, 0]
        cp = cp.to(torch.float64)
        den = cm - 2.0 * best.to(torch.float64) + cp
        ok &= den > 0.0
        step = (cm - cp) / (2.0 * torch.where(ok, den, 1.0))
        val = torch.where(ok, val + step, val)
    if lr_tol >= 0:
        # the right view's costs: right[y, d, xr] = cost[y, d, xr + d] where xr + d < W
        d = torch.arange(n_disp, device=dev)[:, None]
        col = x + d
        inside = col < w
        seen = torch.gather(cost, 2, col.clamp(max=w - 1).expand(h, n_disp, w)).to(torch.int64)
        seen = torch.where(inside, seen, torch.iinfo(torch.int64).max)
        _, d_right = _first_min(seen)
        partner = x - d_left
        partner = torch.where(partner < 0, partner + w, partner).clamp_(0, w - 1)
        fail = (d_left - torch.gather(d_right, 1, partner)).abs() > lr_tol
        val = val.masked_fill(fail, float("inf"))
    return val.to(torch.float32)


def volume_disparity(fl: torch.Tensor, fr: torch.Tensor, n_disp: int, *, scale: float,
                     aggregate: int, lr_tolerance: int | None, subpixel: bool) -> torch.Tensor:
    """(H, W) float32 disparities of (H, C, W) unit features, on their device.

    Parameters
    ----------
    fl, fr : (H, C, W) float32 tensors
        Left and right features (:func:`matcher.learned.cost.features`' values), same device.
    n_disp : int
        Candidates ``d = 0 .. D - 1``, ``1 <= D < W``.
    scale : float
        Cost units per unit of ``1 - cos``.
    aggregate : int
        Box side, odd >= 3, or 1 for none.
    lr_tolerance : int or None
        Largest accepted ``|d_L - d_R|``; None: no left-right check.
    subpixel : bool
        Parabola refinement.

    Returns
    -------
    (H, W) float32 tensor
        ``inf`` where the left-right check fails.
    """
    h, c, w = fl.shape
    lr_tol = -1 if lr_tolerance is None else int(min(lr_tolerance, n_disp))
    halo = aggregate // 2 if aggregate > 1 else 0
    budget = CHUNK_BYTES.get(fl.device.type, CHUNK_BYTES["cpu"])
    rows = max(1, budget // (BYTES_PER_ENTRY * n_disp * w) - 2 * halo)
    out = torch.empty((h, w), dtype=torch.float32, device=fl.device)
    cost_of = _cost_for(fl.device)
    with torch.inference_mode():
        for y0 in range(0, h, rows):
            y1 = min(h, y0 + rows)
            a0, a1 = max(0, y0 - halo), min(h, y1 + halo)
            cost = cost_of(fl[a0:a1], fr[a0:a1], n_disp, scale)
            if aggregate > 1:
                cost = _aggregate(cost, aggregate)
            out[y0:y1] = _select(cost, lr_tol, subpixel)[y0 - a0:y1 - a0]
    return out
