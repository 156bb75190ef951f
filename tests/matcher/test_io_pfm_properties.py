"""Property tests for PFM: bit-exact round trips and robustness to corrupt bytes.

Each property has a hand-picked companion in ``test_io_pfm.py``.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from matcher.io import PFMError, decode_pfm, encode_pfm, read_pfm, read_pfm_header, write_pfm

_shapes = st.tuples(st.integers(1, 12), st.integers(1, 12), st.sampled_from([None, 3])).map(
    lambda t: t[:2] if t[2] is None else t
)
_arrays = _shapes.flatmap(
    lambda s: hnp.arrays(np.float32, s, elements=st.floats(width=32, allow_nan=True, allow_infinity=True))
)
_scales = st.floats(min_value=1e-6, max_value=1e6) | st.floats(min_value=-1e6, max_value=-1e-6)


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


@given(array=_arrays, scale=_scales)
def test_round_trip_is_bit_exact(tmp_path_factory, array, scale):
    path = tmp_path_factory.mktemp("pfm") / "a.pfm"
    write_pfm(path, array, scale=scale)
    out = read_pfm(path)
    assert out.shape == array.shape and out.dtype == np.float32 and out.dtype.isnative
    np.testing.assert_array_equal(_bits(out), _bits(array))  # inf, NaN payloads, -0.0 included
    header = read_pfm_header(path)
    assert header.little_endian == (scale < 0)
    assert header.channels == (3 if array.ndim == 3 else 1)
    assert header.scale == np.float64(scale)
    np.testing.assert_array_equal(_bits(decode_pfm(path.read_bytes())), _bits(array))


@given(array=_arrays, scale=_scales, data=st.data())
def test_every_truncation_raises_pfmerror(tmp_path_factory, array, scale, data):
    blob = encode_pfm(array, scale=scale)
    cut = data.draw(st.integers(0, len(blob) - 1), label="cut")
    path = tmp_path_factory.mktemp("pfm") / "t.pfm"
    path.write_bytes(blob[:cut])
    for decode in (lambda: read_pfm(path), lambda: decode_pfm(blob[:cut])):
        try:
            decode()
        except PFMError:
            pass
        else:
            raise AssertionError(f"a file truncated to {cut} of {len(blob)} bytes was accepted")


def _read_or_pfmerror(path):
    """Read ``path``; return the array or None if it raised PFMError (anything else propagates).

    ``decode_pfm`` of the file's bytes must agree: the same array, or PFMError too.
    """
    try:
        decoded = decode_pfm(path.read_bytes(), where=str(path))
    except PFMError:
        decoded = None
    try:
        out = read_pfm(path)
    except PFMError:
        assert decoded is None, "decode_pfm accepted bytes that read_pfm refused"
        return None
    assert decoded is not None, "decode_pfm refused bytes that read_pfm accepted"
    np.testing.assert_array_equal(_bits(decoded), _bits(out))
    assert out.dtype == np.float32 and out.ndim in (2, 3)
    assert out.size * 4 <= path.stat().st_size  # never more data than the file holds
    return out


@given(
    array=_arrays,
    edits=st.lists(st.tuples(st.integers(0, 40), st.integers(0, 255)), min_size=1, max_size=4),
)
def test_byte_garbage_in_header_parses_or_raises_pfmerror(tmp_path_factory, array, edits):
    blob = bytearray(encode_pfm(array))
    for pos, value in edits:
        if pos < len(blob):
            blob[pos] = value
    path = tmp_path_factory.mktemp("pfm") / "g.pfm"
    path.write_bytes(bytes(blob))
    _read_or_pfmerror(path)


@given(content=st.binary(max_size=200) | st.builds(lambda m, b: m + b, st.sampled_from([b"Pf", b"PF"]), st.binary(max_size=200)))
def test_random_bytes_parse_or_raise_pfmerror(tmp_path_factory, content):
    path = tmp_path_factory.mktemp("pfm") / "r.pfm"
    path.write_bytes(content)
    _read_or_pfmerror(path)


_token = st.one_of(
    st.integers(-(10**12), 10**12).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(alphabet="0123456789+-.eE xnaif\n\t", max_size=8),
)


@given(
    magic=st.sampled_from(["Pf", "PF"]),
    tokens=st.lists(_token, min_size=0, max_size=4),
    seps=st.lists(st.sampled_from([" ", "\n", "\t", "\r\n", ""]), min_size=4, max_size=4),
    payload=st.binary(max_size=64),
)
def test_fuzzed_headers_parse_or_raise_pfmerror(tmp_path_factory, magic, tokens, seps, payload):
    text = magic + "".join(sep + tok for sep, tok in zip(seps, tokens))
    path = tmp_path_factory.mktemp("pfm") / "h.pfm"
    path.write_bytes(text.encode("ascii") + b"\n" + payload)
    _read_or_pfmerror(path)
