"""``match_learned``: the learned cost through census's own aggregation and selection steps."""

from __future__ import annotations

import os

import numpy as np
import torch

from matcher._validation import check_image, check_max_disparity, check_same_shape
from matcher.cost import aggregate_cost
from matcher.learned.cost import COST_SCALE, feature_cost, feature_tensor
from matcher.learned.device import device_name
from matcher.learned.model import LearnedModel, check_inference, load_model
from matcher.learned.volume import volume_disparity
from matcher.result import MatchResult
from matcher.select import winner_takes_all
from stereoforge.validation import check_int

__all__ = ["PIPELINES", "VOLUME_BYTES", "match_learned", "resolve_device"]

#: Most bytes of cost volume (uint16 cost and uint32 aggregate) held at once by match_learned.
VOLUME_BYTES = 64 << 20
#: Where the volume's steps run: ``numba`` (host kernels), ``torch`` (on the features' device),
#: ``auto`` (torch when the features are on a GPU, numba on the CPU).
PIPELINES = ("auto", "numba", "torch")


def resolve_device(device: str) -> torch.device:
    """``"auto"`` (CUDA when torch sees a GPU, else the CPU), ``"cpu"``, ``"cuda"`` or
    ``"cuda:N"`` (:func:`matcher.learned.device.device_name`) as a ``torch.device``.

    Raises
    ------
    ParameterError
        An unknown name, or ``cuda`` without a GPU.
    """
    return torch.device(device_name(device))


def match_learned(left: np.ndarray, right: np.ndarray, model: LearnedModel | str | os.PathLike,
                  *, max_disparity: int, aggregate: int | None = None,
                  lr_check: bool | None = None, lr_tolerance: int = 1,
                  subpixel: bool | None = None, device: str = "cpu",
                  pipeline: str = "auto") -> MatchResult:
    """Disparity of each left pixel under a learned cost.

    The steps are census's (:func:`matcher.match`): the cost volume
    (:func:`matcher.learned.cost.learned_cost`, built in strips of rows), an optional box aggregation
    (:func:`matcher.cost.aggregate_cost`), winner-takes-all with ties to the smallest ``d``, an
    optional left-right check and parabola sub-pixel refinement
    (:func:`matcher.select.winner_takes_all`).

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3) arrays
        Rectified views, grey or RGB (uint8, other integers or float).
    model : LearnedModel or path
        A model (:func:`matcher.learned.load_model`) or its file.
    max_disparity : int
        Candidates ``d = 0 .. D - 1``.
    aggregate, lr_check, subpixel : optional
        Override the model header's inference defaults (box side, odd >= 3, or 1 for none).
    lr_tolerance : int
        Largest accepted ``|d_L - d_R|`` of the left-right check.
    device : str
        Where the network runs: ``cpu``, ``cuda``, ``cuda:N`` or ``auto``.
    pipeline : {"auto", "numba", "torch"}
        Where the cost volume, aggregation, left-right check and selection run: ``numba``
        (host kernels, strips of rows), ``torch`` (:mod:`matcher.learned.volume`, on the
        features' device, chunks of rows), ``auto`` (torch on a GPU, numba on the CPU). Both
        give the same disparities.

    Returns
    -------
    MatchResult
        ``method="learned"``, ``window`` = the network's patch side, ``ops=None``; ``params``
        holds the steps used and the model's path.

    References
    ----------
    J. Žbontar and Y. LeCun, "Stereo matching by training a convolutional neural network to
    compare image patches", JMLR 17(65), 2016.
    """
    if not isinstance(model, LearnedModel):
        model = load_model(model)
    steps = model.inference
    steps = check_inference(steps["aggregate"] if aggregate is None else aggregate,
                            steps["lr_check"] if lr_check is None else lr_check,
                            steps["subpixel"] if subpixel is None else subpixel)
    agg, lr, sub = steps["aggregate"], steps["lr_check"], steps["subpixel"]
    lr_tolerance = check_int(lr_tolerance, "lr_tolerance", lo=0)
    left, right = check_image(left, "left"), check_image(right, "right")
    check_same_shape(left, right)
    h, w = left.shape
    n_disp = check_max_disparity(max_disparity, w)
    dev = resolve_device(device)
    if pipeline not in PIPELINES:
        from stereoforge.errors import ParameterError

        raise ParameterError(f"pipeline: expected one of {', '.join(PIPELINES)}, got {pipeline!r}")
    fl, fr = feature_tensor(model, left, device=dev), feature_tensor(model, right, device=dev)
    if pipeline == "torch" or (pipeline == "auto" and dev.type != "cpu"):
        disparity = volume_disparity(fl, fr, n_disp, scale=COST_SCALE, aggregate=agg,
                                     lr_tolerance=lr_tolerance if lr else None,
                                     subpixel=sub).to("cpu").numpy()
    else:
        disparity = _numba_disparity(fl.to("cpu").numpy(), fr.to("cpu").numpy(), n_disp,
                                     agg, lr, lr_tolerance, sub)
    params = {"aggregate": agg, "lr_check": lr, "lr_tolerance": lr_tolerance, "subpixel": sub,
              "cost_scale": COST_SCALE, "model": str(model.path) if model.path else None,
              "architecture": model.arch.to_dict()}
    return MatchResult(disparity=disparity, ops=None, method="learned", window=model.arch.patch,
                       max_disparity=int(max_disparity), params=params)


def _numba_disparity(fl: np.ndarray, fr: np.ndarray, n_disp: int, agg: int, lr: bool,
                     lr_tolerance: int, sub: bool) -> np.ndarray:
    """The host path: the volume of :func:`feature_cost` in strips of rows."""
    h, _, w = fl.shape
    # strips of rows, each with the box's halo of rows: the aggregation of a strip's rows sees
    # the same rows (and the same edge replication at the image's top and bottom) as on the
    # whole volume, and WTA, the LR check and the parabola work row by row, so the disparity is
    # the whole volume's, bit for bit, with at most VOLUME_BYTES of volume at a time
    halo = agg // 2 if agg > 1 else 0
    rows = max(1, VOLUME_BYTES // (n_disp * w * 6) - 2 * halo)
    disparity = np.empty((h, w), dtype=np.float32)
    for y0 in range(0, h, rows):
        y1 = min(h, y0 + rows)
        a0, a1 = max(0, y0 - halo), min(h, y1 + halo)
        cost = feature_cost(fl[a0:a1], fr[a0:a1], n_disp)
        if agg > 1:
            cost = aggregate_cost(cost, size=agg)
        strip = winner_takes_all(cost, lr_check=lr, lr_tolerance=lr_tolerance, subpixel=sub)
        disparity[y0:y1] = strip[y0 - a0:y1 - a0]
    return disparity
