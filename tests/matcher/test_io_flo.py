"""Middlebury .flo: layout, unknown values, round trips and corrupt input."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from matcher.io import FloError, decode_flo, encode_flo, read_flo, write_flo
from stereoforge.errors import StereoforgeError


def test_layout_is_middlebury_flowio() -> None:
    # flowIO.cpp: "PIEH" (202021.25 as a little-endian float), int32 W, H, then u, v per pixel
    flow = np.array([[[1.0, 2.0], [3.0, 4.0], [np.nan, np.nan]]], np.float32)  # H=1, W=3
    data = encode_flo(flow)
    assert struct.unpack("<f", data[:4])[0] == 202021.25
    assert struct.unpack("<ii", data[4:12]) == (3, 1)
    assert struct.unpack("<6f", data[12:]) == (1.0, 2.0, 3.0, 4.0, 1e10, 1e10)


def test_unknown_above_1e9_reads_as_nan(tmp_path) -> None:
    flow = np.zeros((2, 2, 2), np.float32)
    flow[0, 0] = (np.inf, 0.0)
    flow[1, 1, 1] = 2e9  # beyond UNKNOWN_FLOW_THRESH: unknown, both components
    back = read_flo(write_flo(tmp_path / "f.flo", flow))
    assert np.isnan(back[0, 0]).all() and np.isnan(back[1, 1]).all()
    assert (back[0, 1] == 0).all() and (back[1, 0] == 0).all()


@given(arrays(np.float32, st.tuples(st.integers(1, 6), st.integers(1, 6), st.just(2)),
              elements=st.floats(-1e6, 1e6, width=32)))
def test_round_trip_properties(flow: np.ndarray) -> None:
    np.testing.assert_array_equal(decode_flo(encode_flo(flow)), flow)


@pytest.mark.parametrize("data, match", [
    (b"PIEX" + bytes(8), "bad magic"),
    (b"PIEH\x01\x00", "truncated header"),
    (b"PIEH" + struct.pack("<ii", 0, 3), "width 0"),
    (b"PIEH" + struct.pack("<ii", 2, 2) + bytes(8), "truncated data"),
])
def test_corrupt_input_is_one_format_error(data: bytes, match: str) -> None:
    with pytest.raises(FloError, match=match) as info:
        decode_flo(data, where="x.flo")
    assert isinstance(info.value, StereoforgeError) and str(info.value).startswith("x.flo: ")


def test_writer_refuses_a_wrong_shape() -> None:
    with pytest.raises(ValueError, match=r"\(H, W, 2\)"):
        encode_flo(np.zeros((2, 2, 3), np.float32))
