"""The loss of one training step: the hinge loss of every patch of a batch of crops, crop by
crop (the CPU's default) or the whole batch in one pass (a GPU's), and the validation loss."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch

from matcher.learned import batch_pair_scores, hinge_loss, pair_scores
from synth.jobs.train.patches import Crop

__all__ = ["batch_loss", "one_pass_loss", "val_loss"]

#: Right strips of a one-pass batch are padded to a multiple of this width (few distinct shapes).
_PAD_WIDTH = 64


def _right_tensors(crop: Crop, device: torch.device) -> tuple:
    """A crop's right strip (1, 1, h, w) and its patches' rows, columns, positives, negatives."""
    t = lambda a: torch.from_numpy(np.ascontiguousarray(a)).to(device)  # noqa: E731
    return t(crop.right)[None, None], t(crop.ys), t(crop.xs), t(crop.x_pos), t(crop.x_neg)


def batch_loss(net: torch.nn.Module, batch: list[Crop], device: torch.device
               ) -> tuple[torch.Tensor | None, int]:
    """Mean hinge loss over every patch of a batch, and the number of patches."""
    if not batch:
        return None, 0
    lefts = torch.cat([torch.from_numpy(np.ascontiguousarray(c.left))[None, None]
                       for c in batch]).to(device)
    fl = net(lefts)  # every left block has the same size: one pass
    pos, neg = [], []
    for i, crop in enumerate(batch):
        right, ys, xs, xp, xn = _right_tensors(crop, device)
        sp, sn = pair_scores(fl[i], net(right)[0], ys, xs, xp, xn)
        pos.append(sp)
        neg.append(sn)
    s_pos, s_neg = torch.cat(pos), torch.cat(neg)
    return hinge_loss(s_pos, s_neg), int(s_pos.numel())


def one_pass_loss(net: torch.nn.Module, batch: list[Crop], device: torch.device
                  ) -> tuple[torch.Tensor | None, int]:
    """:func:`batch_loss` with the whole batch in two passes of the network (the lefts, then
    the right strips padded to one width) and every patch's positive and negative sampled at
    once on the device (:func:`matcher.learned.batch_pair_scores`): no per-crop step, which is
    what bounds a GPU. Equal to :func:`batch_loss` up to float rounding."""
    if not batch:
        return None, 0
    r = net.arch.halo
    widths = [c.right.shape[1] for c in batch]
    width = -(-max(widths) // _PAD_WIDTH) * _PAD_WIDTH
    rights = np.zeros((len(batch), 1, batch[0].right.shape[0], width), np.float32)
    for i, crop in enumerate(batch):
        rights[i, 0, :, :widths[i]] = crop.right
    lefts = np.stack([c.left for c in batch])[:, None]
    counts = [c.ys.size for c in batch]
    index = np.repeat(np.arange(len(batch)), counts)
    last = np.repeat(np.asarray(widths) - 2 * r - 1, counts)
    pin = device.type == "cuda"
    t = lambda a: (torch.from_numpy(np.ascontiguousarray(a)).pin_memory() if pin  # noqa: E731
                   else torch.from_numpy(np.ascontiguousarray(a))).to(device, non_blocking=pin)
    cat = np.concatenate
    s_pos, s_neg = batch_pair_scores(
        net(t(lefts)), net(t(rights)), t(index), t(cat([c.ys for c in batch])),
        t(cat([c.xs for c in batch])), t(cat([c.x_pos for c in batch])),
        t(cat([c.x_neg for c in batch])), t(last))
    return hinge_loss(s_pos, s_neg), int(s_pos.numel())


def val_loss(net: torch.nn.Module, batches: list[list[Crop]], device: torch.device,
             step_loss: Callable = batch_loss) -> float | None:
    """The mean loss per patch over fixed validation batches (None without any patch)."""
    if not batches:
        return None
    total, count = 0.0, 0
    with torch.no_grad():
        for batch in batches:
            loss, n = step_loss(net, batch, device)
            if loss is not None:
                total += float(loss) * n
                count += n
    return total / count if count else None
