"""The training objective of the reference network: a hinge on one positive and one negative.

For a left patch ``p`` with true match ``x - d`` in the right view, MC-CNN-fast (Žbontar and
LeCun 2016, §4.1) takes a positive right patch at ``x - d + o_pos`` (``|o_pos| <= 0.5`` px on
Middlebury) and a negative at ``x - d + o_neg`` (``1.5 <= |o_neg| <= 6`` px) and minimises
``max(0, m + s(p, neg) - s(p, pos))`` with ``m = 0.2`` and ``s`` the cosine similarity.

Here the right features are sampled at the non-integer positions by linear interpolation
between the two neighbouring pixels' features (the paper rounds to a pixel); the offsets are
drawn by the data pipeline (``synth.jobs.train``).
"""

from __future__ import annotations

import torch
from torch.nn import functional as F

__all__ = ["MARGIN", "NEGATIVE_OFFSETS", "POSITIVE_OFFSET", "batch_pair_scores", "hinge_loss",
           "pair_scores"]

#: Hinge margin ``m``.
MARGIN = 0.2
#: Largest ``|o_pos|`` of a positive, pixels.
POSITIVE_OFFSET = 0.5
#: Range of ``|o_neg|`` of a negative, pixels.
NEGATIVE_OFFSETS = (1.5, 6.0)


def _sample(fr: torch.Tensor, ys: torch.Tensor, xq: torch.Tensor) -> torch.Tensor:
    """``fr[:, ys, xq]`` with linear interpolation along x; ``0 <= xq <= W - 1``."""
    x0 = torch.floor(xq).long().clamp_(0, fr.shape[2] - 1)
    x1 = (x0 + 1).clamp_(max=fr.shape[2] - 1)
    a = (xq - x0.to(xq.dtype))[None]
    mixed = fr[:, ys, x0] * (1.0 - a) + fr[:, ys, x1] * a
    return F.normalize(mixed, dim=0)


def pair_scores(fl: torch.Tensor, fr: torch.Tensor, ys: torch.Tensor, xs: torch.Tensor,
                x_pos: torch.Tensor, x_neg: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Cosine similarities of left patches with their positives and negatives.

    Parameters
    ----------
    fl : (C, h, w) tensor
        Unit features of a left crop.
    fr : (C, h, wr) tensor
        Unit features of the right strip the matches fall in.
    ys, xs : (N,) int64 tensors
        The left patches (row, column in ``fl``).
    x_pos, x_neg : (N,) float tensors
        Columns in ``fr`` (same row) of each patch's positive and negative, ``0 .. wr - 1``.

    Returns
    -------
    (s_pos, s_neg) : (N,) tensors
        Interpolated right features are re-normalised, so both are cosines in ``[-1, 1]``.
    """
    ref = fl[:, ys, xs]
    return (ref * _sample(fr, ys, x_pos)).sum(0), (ref * _sample(fr, ys, x_neg)).sum(0)


def batch_pair_scores(fl: torch.Tensor, fr: torch.Tensor, crop: torch.Tensor, ys: torch.Tensor,
                      xs: torch.Tensor, x_pos: torch.Tensor, x_neg: torch.Tensor,
                      last: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`pair_scores` of the patches of a whole batch of crops at once (one pass on a GPU).

    Parameters
    ----------
    fl : (B, C, h, w) tensor
        Unit features of the left crops.
    fr : (B, C, h, wr) tensor
        Unit features of the right strips, padded on the right to a common width.
    crop, ys, xs : (N,) int64 tensors
        Each patch's crop and its row and column in ``fl[crop]``.
    x_pos, x_neg : (N,) float tensors
        Columns of its positive and negative in ``fr[crop]``, ``0 .. last``.
    last : (N,) int64 tensor
        The last column of the patch's own strip (its padding is never read).

    Returns
    -------
    (s_pos, s_neg) : (N,) tensors
        The cosines :func:`pair_scores` gives crop by crop (up to float rounding).
    """
    ref = fl[crop, :, ys, xs]  # (N, C)

    def sample(xq: torch.Tensor) -> torch.Tensor:
        x0 = torch.minimum(torch.floor(xq).long().clamp_(min=0), last)
        x1 = torch.minimum(x0 + 1, last)
        a = (xq - x0.to(xq.dtype))[:, None]
        mixed = fr[crop, :, ys, x0] * (1.0 - a) + fr[crop, :, ys, x1] * a
        return F.normalize(mixed, dim=1)

    return (ref * sample(x_pos)).sum(1), (ref * sample(x_neg)).sum(1)


def hinge_loss(s_pos: torch.Tensor, s_neg: torch.Tensor, *, margin: float = MARGIN
               ) -> torch.Tensor:
    """Mean of ``max(0, margin + s_neg - s_pos)``.

    Examples
    --------
    >>> import torch
    >>> float(hinge_loss(torch.tensor([0.9, 0.5]), torch.tensor([0.1, 0.6])))
    0.15000000596046448
    """
    return F.relu(margin + s_neg - s_pos).mean()
