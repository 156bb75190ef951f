"""Properties of configuration distributions: draws stay in range and follow the seed."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from synth.dataset.config.parse import Dist, loads_config

bounds = st.tuples(st.floats(0.01, 10.0), st.floats(0.01, 10.0)).map(sorted)


@given(bounds, st.sampled_from(["uniform", "loguniform"]), st.integers(0, 2**32))
def test_float_draws_stay_in_their_interval(ab, kind, seed):
    a, b = ab
    d = Dist(kind, (a, b))
    rng = np.random.default_rng(seed)
    x = [d.sample(rng) for _ in range(20)]
    assert all(a <= v <= b for v in x)


def test_float_draws_example():
    d = Dist("uniform", (0.5, 0.5))
    assert d.sample(np.random.default_rng(0)) == 0.5


@given(st.floats(0.0, 64.0), st.integers(0, 100))
def test_any_in_range_value_parses_and_round_trips(sigma, quality):
    cfg = loads_config(f"[photometric]\nnoise_sigma = {sigma!r}\njpeg_quality = {quality}\n")
    assert cfg.photometric["noise_sigma"].to_toml() == sigma
    assert cfg.photometric["jpeg_quality"].to_toml() == quality


def test_in_range_value_example():
    cfg = loads_config("[photometric]\nnoise_sigma = 64.0\n")
    assert cfg.photometric["noise_sigma"].to_toml() == 64.0
