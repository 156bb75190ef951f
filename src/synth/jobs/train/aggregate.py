"""The box aggregation a model uses by default: the side of :data:`AGGREGATES` with the smallest
bad-3 on the validation pairs, chosen once training has ended."""

from __future__ import annotations

import math

import numpy as np
import torch

from matcher.learned.model import LearnedModel
from synth.jobs.train.sources import TrainPair, TrainSource

__all__ = ["AGGREGATES", "SELECT_PAIRS", "aggregate_bad3", "choose_aggregate"]

#: Box sides (1 = none) tried for the model's default aggregation.
AGGREGATES = (1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21)
#: Validation pairs the aggregation is chosen on.
SELECT_PAIRS = 4


def _search_range(disp: np.ndarray, visible: np.ndarray, width: int) -> int:
    top = float(disp[visible].max()) if visible.any() else 16.0
    return int(min(width - 1, max(4, 4 * math.ceil(math.ceil(1.1 * top + 1) / 4))))


def aggregate_bad3(model: LearnedModel, pair: TrainPair, device: str | torch.device = "cpu"
                   ) -> np.ndarray:
    """bad-3 (%, all pixels with ground truth, no estimate = bad) of ``model`` on one pair with
    each box side of :data:`AGGREGATES` (sub-pixel on, no left-right check), in that order."""
    from matcher.cost import aggregate_cost
    from matcher.learned import learned_cost
    from matcher.select import winner_takes_all

    known = pair.disp > 0
    cost = learned_cost(model, pair.left, pair.right, device=device,
                        max_disparity=_search_range(pair.disp, known, pair.left.shape[1]))
    bad = np.zeros(len(AGGREGATES))
    for a, size in enumerate(AGGREGATES):
        vol = cost if size == 1 else aggregate_cost(cost, size=size)
        est = winner_takes_all(vol, subpixel=True)
        err = np.abs(est - pair.disp)[known]
        bad[a] = 100.0 * float(np.mean(~(err <= 3.0)))
    return bad


def choose_aggregate(model: LearnedModel, sources: list[TrainSource], device: torch.device
                     ) -> tuple[int, list]:
    """The box side of :data:`AGGREGATES` with the smallest bad-3 (:func:`aggregate_bad3`) over
    up to :data:`SELECT_PAIRS` validation pairs; 5 without any."""
    pairs = [(s, i) for s in sources for i in range(s.n_val)][:SELECT_PAIRS]
    if not pairs:
        return 5, []
    bad = np.zeros(len(AGGREGATES))
    for s, i in pairs:
        bad += aggregate_bad3(model, s.load("val", i), device)
    bad /= len(pairs)
    return int(AGGREGATES[int(np.argmin(bad))]), [round(float(b), 3) for b in bad]
