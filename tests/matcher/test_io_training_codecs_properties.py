"""Property tests for the disparity codecs of the training layouts (CREStereo, FSD): round trips
within each quantum with the exact ``inf`` mask, the range and precision refusals, and corrupt
or truncated files raising :class:`FormatError`.

Hand-picked companions in ``test_io_training_codecs.py``: ``test_crestereo_round_trip_example``,
``test_fsd_round_trip_example``, ``test_crestereo_refuses_what_it_cannot_store``,
``test_fsd_refuses_what_it_cannot_store``, ``test_check_crestereo_range``, ``test_check_fsd_range``,
``test_crestereo_corrupt_and_truncated_files_raise_formaterror``.
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from matcher.io import (
    CRESTEREO_MAX,
    FSD_MAX,
    check_crestereo_range,
    check_fsd_range,
    decode_crestereo_disparity,
    decode_fsd_disparity,
    encode_crestereo_disparity,
    encode_fsd_disparity,
)
from stereoforge.errors import FormatError


class Codec(NamedTuple):
    encode: object
    decode: object
    check_range: object
    scale: int
    max_disparity: float


CODECS = {
    "crestereo": Codec(encode_crestereo_disparity, decode_crestereo_disparity, check_crestereo_range,
                       32, CRESTEREO_MAX),
    "fsd": Codec(encode_fsd_disparity, decode_fsd_disparity, check_fsd_range, 1000, FSD_MAX),
}
codec_names = pytest.mark.parametrize("name", sorted(CODECS))


def _stored_codes(png: bytes, scale: int) -> np.ndarray:
    """The integer codes in the file, read with OpenCV (not with the codec under test)."""
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED).astype(np.int64)
    if image.ndim == 2:
        return image
    return image[..., 2] * 255 * 255 + image[..., 1] * 255 + image[..., 0]  # B, G, R -> R*255^2 ...


def _storable(codec: Codec):
    """float32 disparities the codec holds: above half a quantum, up to its maximum."""
    lo = float(np.nextafter(np.float32(0.5 / codec.scale), np.float32(np.inf)))
    hi = float(np.float32(codec.max_disparity))  # 2047.96875 exactly; 16581.373047 (code 16581373)
    assert codec.max_disparity - 0.002 < hi <= codec.max_disparity
    return st.floats(lo, hi, width=32) | st.sampled_from([np.inf, np.nan])


def _maps(elements):
    shapes = st.tuples(st.integers(1, 16), st.integers(1, 16))
    return shapes.flatmap(lambda s: hnp.arrays(np.float32, s, elements=elements))


@codec_names
@given(data=st.data())
def test_round_trip_within_half_a_quantum_and_exact_inf_mask(name, data):
    codec = CODECS[name]
    disp = data.draw(_maps(_storable(codec)), label="disp")
    png = codec.encode(disp)
    out = codec.decode(png)
    assert out.dtype == np.float32 and out.shape == disp.shape
    finite = np.isfinite(disp)
    np.testing.assert_array_equal(np.isinf(out), ~finite)  # inf exactly where there is no GT
    assert not np.isnan(out).any()
    d = disp[finite].astype(np.float64)
    codes = _stored_codes(png, codec.scale)
    assert (codes[~finite] == 0).all() and (codes[finite] >= 1).all()
    # the stored code is within half a quantum of the disparity ...
    assert (np.abs(codes[finite] / codec.scale - d) <= 0.5 / codec.scale + 1e-12).all()
    # ... and the float32 returned is that code's value, to float32's rounding
    bound = 0.5 / codec.scale + np.spacing(np.abs(d).astype(np.float32)).astype(np.float64)
    assert (np.abs(out[finite].astype(np.float64) - d) <= bound).all()
    assert codec.encode(disp) == png  # same map, same bytes


@given(disp=_maps(_storable(CODECS["crestereo"])))
def test_crestereo_round_trip_is_within_1_64_px_exactly(disp):
    """code / 32 is exact in float32: the bound needs no float32 slack."""
    out = decode_crestereo_disparity(encode_crestereo_disparity(disp))
    finite = np.isfinite(disp)
    assert (np.abs(out[finite].astype(np.float64) - disp[finite]) <= 1 / 64).all()


@codec_names
@given(data=st.data())
def test_values_it_cannot_store_are_refused_never_clipped(name, data):
    codec = CODECS[name]
    disp = data.draw(_maps(_storable(codec)), label="disp")
    bad = data.draw(st.one_of(
        st.floats(max_value=-1e-30, allow_infinity=True, allow_nan=False),  # negative, -inf
        st.floats(min_value=codec.max_disparity + 0.5 / codec.scale + 1e-9, max_value=1e30,
                  allow_infinity=False),  # its code would exceed the largest
        st.floats(min_value=0.0, max_value=0.5 / codec.scale),  # its code would be 0
    ), label="bad")
    i = data.draw(st.integers(0, disp.shape[0] - 1), label="row")
    j = data.draw(st.integers(0, disp.shape[1] - 1), label="column")
    disp = disp.astype(np.float64)
    disp[i, j] = bad
    with pytest.raises(ValueError) as info:
        codec.encode(disp)
    assert str(info.value).startswith("disp: expected ")
    assert " at row " in str(info.value)


@codec_names
@given(lo=st.floats(-10.0, 20000.0), hi=st.floats(-10.0, 20000.0))
def test_check_range_agrees_with_the_encoder(name, lo, hi):
    """check_*_range(lo, hi) passes exactly when a map holding lo and hi (lo <= hi) encodes."""
    codec = CODECS[name]
    try:
        codec.check_range(lo, hi)
    except ValueError:
        ok = False
    else:
        ok = True
    if lo > hi:
        assert not ok
        return
    try:
        codec.encode(np.array([[lo, hi]]))
    except ValueError:
        encodes = False
    else:
        encodes = True
    assert ok == encodes


@codec_names
@given(data=st.data())
def test_corrupt_or_truncated_files_raise_formaterror_or_decode_to_their_shape(name, data):
    codec = CODECS[name]
    disp = data.draw(_maps(_storable(codec)), label="disp")
    png = codec.encode(disp)
    cut = data.draw(st.integers(0, len(png) - 1), label="cut")
    with pytest.raises(FormatError):
        codec.decode(png[:cut])
    edits = data.draw(st.lists(st.tuples(st.integers(0, len(png) - 1), st.integers(1, 255)),
                               min_size=1, max_size=3), label="edits")
    broken = bytearray(png)
    for pos, xor in edits:
        broken[pos] ^= xor
    try:
        out = codec.decode(bytes(broken))
    except FormatError:
        return
    assert out.dtype == np.float32 and out.ndim == 2  # what was decoded is a map, not garbage
    assert not np.isnan(out).any() and (out > 0).all()
