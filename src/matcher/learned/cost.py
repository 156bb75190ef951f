"""The learned cost: features once per view, then a quantised cosine cost volume.

``cost[y, d, x] = round((1 - cos(f_L(y, x), f_R(y, x - d))) * cost_scale)`` as uint16, with the
census volumes' conventions (:mod:`matcher.cost`): layout ``(H, D, W)``, :data:`COST_SENTINEL`
where ``x - d < 0``. So :func:`matcher.cost.aggregate_cost` and
:func:`matcher.select.winner_takes_all` take it as they take a Hamming volume, and a learned and a
census matcher differ only in the cost.

Memory stays bounded: the features of a view are computed in strips of rows (each with the
network's halo), and the cost is written row by row straight into the uint16 volume by a numba
kernel, never as a float volume; :func:`matcher.learned.match_learned` builds, aggregates and
selects the volume in strips of rows too (:func:`feature_cost` on a slice of the features).
"""

from __future__ import annotations

import numba
import numpy as np
import torch

from matcher._kernels import similarity_cost_kernel
from matcher._validation import check_image, check_max_disparity, check_same_shape
from matcher.learned.model import LearnedModel
from matcher.learned.network import standardise

__all__ = ["COST_SCALE", "STRIP_PIXELS", "feature_cost", "feature_tensor", "features",
           "learned_cost"]

#: Cost units per unit of ``1 - cos``: costs span 0 .. 2 * COST_SCALE (16384), so a box sum over
#: up to 511 x 511 pixels fits the uint32 of :func:`matcher.cost.aggregate_cost`.
COST_SCALE = 8192.0
#: Largest strip of a view pushed through the network at once (pixels, halo excluded).
STRIP_PIXELS = 1 << 16


def features(model: LearnedModel, image: np.ndarray, *, device: str | torch.device = "cpu"
             ) -> np.ndarray:
    """Unit feature vectors of every pixel of one view.

    The view is standardised (:func:`matcher.learned.network.standardise`), padded by the
    network's halo (:attr:`matcher.learned.registry.Arch.halo`) with its edge replicated (as census pads), and run through the network
    in strips of rows.

    Parameters
    ----------
    model : LearnedModel
    image : (H, W) or (H, W, 3) array
        Grey or RGB view (uint8, other integers or float).
    device : str or torch.device
        Where the network runs (its weights are moved there).

    Returns
    -------
    (H, C, W) float32 array
        Channel-planar, the layout of the cost kernel.
    """
    return feature_tensor(model, image, device=device).to("cpu").numpy()


def feature_tensor(model: LearnedModel, image: np.ndarray, *,
                   device: str | torch.device = "cpu") -> torch.Tensor:
    """:func:`features` as an (H, C, W) float32 tensor left on ``device``."""
    grey = check_image(image, "image")
    r = model.arch.halo
    h, w = grey.shape
    padded = np.pad(standardise(grey), r, mode="edge")
    net = model.net.to(device)
    out = torch.empty((h, model.arch.features, w), dtype=torch.float32, device=device)
    rows = max(1, STRIP_PIXELS // max(w, 1))
    with torch.inference_mode():
        for y0 in range(0, h, rows):
            y1 = min(h, y0 + rows)
            strip = torch.from_numpy(padded[y0:y1 + 2 * r])[None, None].to(device)
            feat = net(strip.contiguous(memory_format=torch.channels_last))[0]
            out[y0:y1] = feat.permute(1, 0, 2)
    return out


def learned_cost(model: LearnedModel, left: np.ndarray, right: np.ndarray, *,
                 max_disparity: int, device: str | torch.device = "cpu") -> np.ndarray:
    """The (H, D, W) uint16 cost volume of a pair under ``model``.

    Parameters
    ----------
    model : LearnedModel
    left, right : (H, W) or (H, W, 3) arrays
        The rectified views (grey or RGB).
    max_disparity : int
        Candidates ``d = 0 .. D - 1``, ``1 <= D < W``.
    device : str or torch.device
        Where the network runs; the cost is computed on the CPU.

    Returns
    -------
    (H, D, W) uint16 array
        ``round((1 - cos) * COST_SCALE)``; :data:`matcher.cost.COST_SENTINEL` where ``x - d < 0``.
    """
    left, right = check_image(left, "left"), check_image(right, "right")
    check_same_shape(left, right)
    n_disp = check_max_disparity(max_disparity, left.shape[1])
    return feature_cost(features(model, left, device=device),
                        features(model, right, device=device), n_disp)


def feature_cost(fl: np.ndarray, fr: np.ndarray, n_disp: int) -> np.ndarray:
    """The (h, D, W) uint16 cost volume of rows of features (:func:`features`, sliced by rows:
    a strip of the volume needs only its own rows)."""
    h, _, w = fl.shape
    out = np.empty((h, n_disp, w), dtype=np.uint16)
    similarity_cost_kernel(np.ascontiguousarray(fl), np.ascontiguousarray(fr),
                           np.float32(COST_SCALE), numba.get_num_threads(),
                           np.zeros(1, np.int64), out)
    return out
