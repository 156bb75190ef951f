"""Property: format_calib -> parse_calib round-trips every finite value exactly.

Hand-picked companion: ``test_parse_real_middlebury_calib_and_format_reproduces_it``.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from matcher.io import format_calib, parse_calib

_reals = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12)


@given(
    cam0=hnp.arrays(np.float64, (3, 3), elements=_reals),
    doffs=_reals,
    baseline=st.floats(min_value=1e-6, max_value=1e6),
    size=st.tuples(st.integers(1, 10000), st.integers(1, 10000)),
    ndisp=st.integers(1, 1000),
    vmin=_reals | st.integers(-1000, 1000),
)
def test_calib_round_trip(cam0, doffs, baseline, size, ndisp, vmin):
    calib = {"cam0": cam0, "cam1": cam0.T, "doffs": doffs, "baseline": baseline,
             "width": size[0], "height": size[1], "ndisp": ndisp, "vmin": vmin}
    back = parse_calib(format_calib(calib))
    assert set(back) == set(calib)
    for key, value in calib.items():
        np.testing.assert_array_equal(np.asarray(back[key], np.float64), np.asarray(value, np.float64))
    assert all(type(back[k]) is int for k in ("width", "height", "ndisp"))
