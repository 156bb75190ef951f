"""The learned matcher's quantised cost volume in one Triton kernel (a CUDA GPU).

:func:`matcher.learned.volume._cost` builds the volume with two whole-volume torch operations
per feature channel (a product, then a sum into the accumulator): at 1280 x 960 x 256
disparities x 32 channels that is ~160 GB of memory traffic, most of the learned matcher's time
on a GPU. This kernel keeps the accumulator of a tile of ``(d, x)`` in registers, loops over the
channels there, and writes only the quantised int32 costs: the same numbers, bit for bit,
because it does the same float32 operations in the same order (one product, then one sum, per
channel from the first, then ``(1 - acc) * scale + 0.5`` clamped to ``[0, 65534]`` and
truncated) and is compiled with ``enable_fp_fusion=False`` (no fused multiply-add where torch
and the numba kernel round twice). ``TRITON_INTERPRET=1`` runs it on the CPU (numpy), which is
how the tests check it against the torch and numba paths without a GPU.

Importing this module needs ``triton`` (shipped with torch's CUDA builds on Linux).
"""

from __future__ import annotations

import torch
import triton
import triton.language as tl

__all__ = ["BLOCK_D", "BLOCK_X", "cost"]

#: Tile of one program: disparities x columns.
BLOCK_D, BLOCK_X = 32, 64
_COST_SENTINEL = tl.constexpr(65535)
_TOP = tl.constexpr(65534.0)


@triton.jit
def _cost_kernel(fl, fr, out, channels, width, n_disp, scale,
                 BD: tl.constexpr, BX: tl.constexpr):  # pragma: no cover - compiled
    y = tl.program_id(0).to(tl.int64)
    xs = tl.program_id(1) * BX + tl.arange(0, BX)
    ds = tl.program_id(2) * BD + tl.arange(0, BD)
    src = xs[None, :] - ds[:, None]
    inside = (xs[None, :] < width) & (ds[:, None] < n_disp)
    valid = inside & (src >= 0)
    # tl.full, a builtin: tl.zeros is a @jit function, which Triton's interpreter cannot run when
    # triton.language was imported before TRITON_INTERPRET was set (torch imports it)
    acc = tl.full((BD, BX), 0.0, dtype=tl.float32)
    for ch in range(channels):
        row = (y * channels + ch) * width
        a = tl.load(fl + row + xs, mask=xs < width, other=0.0)
        b = tl.load(fr + row + src, mask=valid, other=0.0)
        acc = acc + a[None, :] * b
    val = (1.0 - acc) * scale + 0.5
    val = tl.minimum(tl.maximum(val, 0.0), _TOP)
    cost = tl.where(valid, val.to(tl.int32), _COST_SENTINEL)
    tl.store(out + (y * n_disp + ds[:, None]) * width + xs[None, :], cost, mask=inside)


def cost(fl: torch.Tensor, fr: torch.Tensor, n_disp: int, scale: float) -> torch.Tensor:
    """(h, D, W) int32 quantised costs of (h, C, W) float32 features (see
    :func:`matcher.learned.volume._cost`, whose numbers these are)."""
    fl, fr = fl.contiguous(), fr.contiguous()
    h, c, w = fl.shape
    out = torch.empty((h, n_disp, w), dtype=torch.int32, device=fl.device)
    grid = (h, triton.cdiv(w, BLOCK_X), triton.cdiv(n_disp, BLOCK_D))
    _cost_kernel[grid](fl, fr, out, c, w, n_disp, float(scale), BD=BLOCK_D, BX=BLOCK_X,
                       enable_fp_fusion=False)
    return out
