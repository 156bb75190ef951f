"""Census on the paper's six Middlebury scenes (third size) against the paper's Table 1."""

from __future__ import annotations

import pytest

from matcher import match
from matcher.io import load_middlebury_2005
from matcher.metrics import evaluate

SCENES = ("Moebius", "Flowerpots", "Reindeer", "Cloth2", "Midd1", "Baby1")
# Table 1 of the seed paper, CT column, PoBMP (%) with delta = 3.
PAPER_CT = {
    3: (78.75, 79.11, 82.84, 71.59, 84.97, 72.06),
    7: (39.35, 59.14, 45.58, 31.84, 58.33, 40.11),
    13: (24.66, 47.18, 32.23, 23.27, 48.17, 23.37),
}


@pytest.mark.realdata
@pytest.mark.parametrize("window", sorted(PAPER_CT))
def test_ct_within_5_points_of_table1_on_4_of_6_scenes(middlebury_dir, window):
    ours = []
    for scene in SCENES:
        sample = load_middlebury_2005(middlebury_dir / "third" / scene, divisor=3)
        res = match(sample.left, sample.right, method="ct", window=window, max_disparity=85)
        ours.append(evaluate(res.disparity, sample.disp_left, delta=3.0).pobmp)
    close = [abs(o - p) <= 5.0 for o, p in zip(ours, PAPER_CT[window], strict=True)]
    assert sum(close) >= 4, dict(zip(SCENES, ours, strict=True))
