"""Properties of CTHW's path search, against a direct walk, with a hand-picked example."""

from __future__ import annotations

from collections import Counter

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from matcher.cthw import modify_disparity


def _walk_reference(disp, edges, include_edge, include_self, max_path):
    h, w = disp.shape
    out = np.full((h, w), np.inf, np.float32)
    for y in range(h):
        for x in range(w):
            votes = Counter()
            if include_self and np.isfinite(disp[y, x]):
                votes[int(disp[y, x])] += 1
            for dy, dx in ((0, -1), (0, 1), (-1, 0), (1, 0)):
                yy, xx, steps = y + dy, x + dx, 0
                while 0 <= yy < h and 0 <= xx < w and (max_path is None or steps < max_path):
                    if edges[yy, xx] and not include_edge:
                        break
                    if np.isfinite(disp[yy, xx]):
                        votes[int(disp[yy, xx])] += 1
                    if edges[yy, xx]:
                        break
                    yy, xx, steps = yy + dy, xx + dx, steps + 1
            if votes:
                top = max(votes.values())
                out[y, x] = min(d for d, c in votes.items() if c == top)
    return out


@st.composite
def path_inputs(draw):
    h = draw(st.integers(1, 12))
    w = draw(st.integers(1, 12))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    disp = rng.integers(0, draw(st.integers(1, 6)), (h, w)).astype(np.float32)
    disp[rng.random((h, w)) < draw(st.sampled_from([0.0, 0.2]))] = np.inf
    edges = rng.random((h, w)) < draw(st.sampled_from([0.0, 0.1, 0.4, 0.9]))
    return disp, edges


@given(path_inputs(), st.booleans(), st.booleans(), st.sampled_from([None, 1, 2, 5]))
def test_path_search_equals_a_direct_walk(inputs, include_edge, include_self, max_path):
    disp, edges = inputs
    got = modify_disparity(disp, edges, include_edge=include_edge, include_self=include_self,
                           max_path=max_path)
    ref = _walk_reference(disp, edges, include_edge, include_self, max_path)
    assert np.array_equal(got, ref)


def test_direct_walk_example():
    disp = np.array([[0, 3, 3], [2, 1, np.inf], [2, 2, 0]], np.float32)
    edges = np.array([[False, True, False], [False, False, False], [True, False, False]])
    got = modify_disparity(disp, edges, include_edge=True)
    assert np.array_equal(got, _walk_reference(disp, edges, True, True, None))
    # (1, 1): self 1; left 2; right inf; up 3 (edge, included); down 2 -> 2
    assert got[1, 1] == 2


@given(path_inputs())
def test_no_edges_and_constant_disparity_is_a_fixed_point(inputs):
    disp, _ = inputs
    const = np.where(np.isfinite(disp), 3, np.inf).astype(np.float32)
    got = modify_disparity(const, np.zeros(disp.shape, bool))
    assert np.all(got[np.isfinite(got)] == 3)
    assert np.all(np.isfinite(got[np.isfinite(disp)]))  # a valid pixel votes for itself


def test_fixed_point_example():
    assert modify_disparity(np.full((3, 4), 2, np.float32), np.zeros((3, 4), bool)).tolist() == [
        [2.0] * 4] * 3
