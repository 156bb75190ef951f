"""The shared validators: what they accept, convert, and the one message format of a refusal."""

from __future__ import annotations

import numpy as np
import pytest

from stereoforge.errors import ParameterError, ParameterTypeError, SceneError
from stereoforge.schema import Key, check_table
from stereoforge.validation import (
    check_array,
    check_bool,
    check_choice,
    check_dtype,
    check_finite,
    check_int,
    check_keys,
    check_real,
    check_sequence,
    check_shape,
    check_text,
    check_type,
    describe,
    fail,
    range_text,
)


def test_message_format_names_where_parameter_expected_actual_and_fix():
    exc = fail("rig.width", "an integer in [8, 8192]", "4", fix="use 8 or more", where="my.toml:5")
    assert str(exc) == "my.toml:5: rig.width: expected an integer in [8, 8192], got 4; use 8 or more"
    assert isinstance(exc, ParameterError)
    assert str(fail("x", "a", "b")) == "x: expected a, got b"


@pytest.mark.parametrize(
    ("lo", "hi", "lo_open", "hi_open", "text"),
    [(0, 4, True, False, "in (0, 4]"), (0.0, 1.0, False, True, "in [0.0, 1.0)"),
     (3, None, False, False, ">= 3"), (0, None, True, False, "> 0"),
     (None, 1, False, True, "< 1"), (None, 2.5, False, False, "<= 2.5"),
     (None, None, False, False, "")],
)
def test_range_text(lo, hi, lo_open, hi_open, text):
    assert range_text(lo, hi, lo_open=lo_open, hi_open=hi_open) == text


def test_bool_is_not_an_int_and_an_int_is_not_a_bool():
    assert check_bool(True, "flag") is True and check_bool(np.False_, "flag") is False
    with pytest.raises(ParameterTypeError, match=r"^flag: expected True or False, got int 1$"):
        check_bool(1, "flag")
    for value in (True, np.True_):
        with pytest.raises(ParameterTypeError, match="expected an integer, got bool"):
            check_int(value, "n")
        with pytest.raises(ParameterTypeError, match="expected a finite number, got bool"):
            check_real(value, "x")


def test_int_accepts_numpy_integers_and_refuses_floats():
    out = check_int(np.uint8(7), "n", lo=0, hi=10)
    assert out == 7 and type(out) is int
    with pytest.raises(ParameterTypeError, match=r"^n: expected an integer in \[0, 10\], got "
                                                 r"float 7\.0$"):
        check_int(7.0, "n", lo=0, hi=10)


@pytest.mark.parametrize(
    ("kwargs", "value", "ok"),
    [({"lo": 0, "lo_open": True}, 0, False), ({"lo": 0}, 0, True), ({"hi": 3, "hi_open": True}, 3, False),
     ({"hi": 3}, 3, True), ({"lo": 3, "odd": True}, 4, False), ({"lo": 3, "odd": True}, 5, True),
     ({"lo": 3, "odd": True}, 1, False)],
)
def test_int_bounds_are_open_or_closed(kwargs, value, ok):
    if ok:
        assert check_int(value, "n", **kwargs) == value
    else:
        with pytest.raises(ParameterError, match=f"got {value}$"):
            check_int(value, "n", **kwargs)


def test_real_finite_bounds_and_conversion():
    out = check_real(np.float32(0.5), "x", lo=0.0, hi=1.0)
    assert out == 0.5 and type(out) is float
    assert check_real(float("inf"), "x", finite=False) == float("inf")
    with pytest.raises(ParameterError, match=r"^x: expected a number >= 0, got nan$"):
        check_real(float("nan"), "x", lo=0, finite=False)
    with pytest.raises(ParameterError, match=r"^x: expected a finite number, got inf$"):
        check_real(float("inf"), "x")
    with pytest.raises(ParameterError, match=r"expected a finite number in \(0, 4\], got 0\.0"):
        check_real(0.0, "gain", lo=0, hi=4, lo_open=True)
    with pytest.raises(ParameterTypeError, match=r"got str '1'"):
        check_real("1", "x")


def test_choice_suggests_the_closest_and_keeps_bool_apart_from_int():
    assert check_choice("box", "kind", ["box", "sphere"]) == "box"
    with pytest.raises(ParameterError, match=r"^kind: expected one of \['box', 'sphere'\], got "
                                             r"'spere'; did you mean 'sphere'\?$"):
        check_choice("spere", "kind", ["box", "sphere"])
    with pytest.raises(ParameterError, match="got True"):
        check_choice(True, "q", [0, 1])
    with pytest.raises(ParameterError, match=r"got array\(\[1, 2\]\)"):  # no elementwise ==
        check_choice(np.array([1, 2]), "q", [1, 2])


def test_type_names_the_class_with_its_article():
    assert check_type(3, "n", int) == 3
    with pytest.raises(ParameterTypeError, match=r"^spec: expected an ObjectSpec or a dict, got "
                                                 r"int 3$"):
        check_type(3, "spec", (type("ObjectSpec", (), {}), dict))


def test_sequence_length_entries_and_distinct():
    assert check_sequence([1, 2], "v", item=lambda v, n: check_real(v, n)) == (1.0, 2.0)
    with pytest.raises(ParameterTypeError, match=r"^v: expected a sequence of 3 numbers, got str"):
        check_sequence("abc", "v", length=3, of="numbers")
    with pytest.raises(ParameterError, match=r"^v\[1\]: expected a finite number >= 0, got -1\.0$"):
        check_sequence([1, -1], "v", item=lambda v, n: check_real(v, n, lo=0))
    with pytest.raises(ParameterError, match=r"expected distinct values, got 5 twice in \[5, 5\]; "
                                             r"remove the repeated 5"):
        check_sequence([5, 5], "windows", distinct=True)
    with pytest.raises(ParameterError, match=r"^s: expected a non-empty array of integers, got 0 "
                                             r"entries \(\)$"):
        check_sequence([], "s", nonempty=True, noun="array", of="integers")
    with pytest.raises(ParameterTypeError, match="got dict"):
        check_sequence({"a": 1}, "v")


def test_array_dtype_shape_finite():
    a = np.zeros((2, 3), np.float32)
    assert check_array(a, "d") is a
    assert check_dtype(a, "d", kinds="f") is a and check_dtype(a, "d", dtypes=[np.float32]) is a
    assert check_shape(a, "d", ("H", 3)) is a and check_shape(a, "d", (None, None)) is a
    assert check_finite(a, "d") is a
    with pytest.raises(ParameterTypeError, match=r"^d: expected a numpy array, got list \[1\]; "
                                                 r"convert with np\.asarray$"):
        check_array([1], "d")
    with pytest.raises(ParameterTypeError, match=r"^d: expected dtype uint8, got dtype float32$"):
        check_dtype(a, "d", dtypes=[np.uint8])
    with pytest.raises(ParameterError, match=r"^d: expected shape \(H, W, 3\), got \(2, 3\)$"):
        check_shape(a, "d", ("H", "W", 3))
    with pytest.raises(ParameterError, match=r"^d: expected finite values, got 2 NaN/inf \(of 6\)"):
        check_finite(np.array([[np.nan, 0, 0], [0, np.inf, 0]]), "d")


def test_keys_name_the_unknown_one_the_valid_ones_and_the_closest():
    assert check_keys({"gain": 1}, "P", ["gain"]) == {"gain": 1}
    with pytest.raises(SceneError, match=r"^objects\[0\]: unknown key 'texure' in the object; "
                                         r"valid keys: \['kind', 'texture'\]; did you mean "
                                         r"'texture'\?$"):
        check_keys({"texure": 1}, "the object", ["kind", "texture"], where="objects[0]",
                   error=SceneError)


def test_key_schema_describes_and_checks():
    windows = Key("int", (5,), lo=3, hi=255, odd=True, array=True, distinct=True)
    assert windows.expected() == "a non-empty array of odd integers in [3, 255]"
    assert windows.check([5, 7.0], "match.windows") == (5, 7)
    with pytest.raises(ParameterError, match=r"^s\.toml:9: match\.windows\[1\]: expected an odd "
                                             r"integer in \[3, 255\], got 8$"):
        windows.check([5, 8], "match.windows", where="s.toml:9")
    kinds = Key("str", ("a",), choices=("a", "b"), array=True)
    assert kinds.expected() == "a non-empty array of values in ['a', 'b']"
    assert Key("bool", False).check(True, "preview") is True
    with pytest.raises(ParameterTypeError, match=r"preview: expected true or false, got int 1"):
        Key("bool", False).check(1, "preview")
    assert Key("float", None).optional and not Key("float", 1.0).optional
    with pytest.raises(ParameterError, match="Key.kind"):
        Key("list", None)


def test_table_checks_unknown_keys_and_values_with_their_location():
    schema = {"width": Key("int", 640, lo=8), "fx": Key("float", None, lo=0, lo_open=True)}
    where = {"width": "f.toml:2", "widht": "f.toml:3"}.get
    assert check_table({"fx": 3}, "[rig]", schema, path="rig") == {"fx": 3.0}
    with pytest.raises(ParameterError, match=r"^f\.toml:3: unknown key 'widht' in \[rig\]; "
                                             r"valid keys: \['width', 'fx', 'sub'\]; did you mean "
                                             r"'width'\?$"):
        check_table({"widht": 3}, "[rig]", schema, path="rig", where=where, skip=("sub",))
    with pytest.raises(ParameterError, match=r"^f\.toml:2: rig\.width: expected an integer >= 8"):
        check_table({"width": 3}, "[rig]", schema, path="rig", where=where)
    with pytest.raises(ParameterTypeError, match=r"^\[rig\]: expected a table, got int 3$"):
        check_table(3, "[rig]", schema)


def test_describe_shortens_long_values():
    assert describe("x" * 200).endswith("...") and len(describe("x" * 200)) < 100
    assert describe(np.zeros((2,), bool)) == "array of shape (2,) and dtype bool"


def test_text_drops_a_utf8_byte_order_mark_and_counts_bad_bytes_in_the_file():
    bom = b"\xef\xbb\xbf"
    assert check_text(bom + b"a = 1\nb = 2\n", "x.toml") == "a = 1\nb = 2\n"
    assert check_text(b"a = 1", "x.toml") == "a = 1"
    with pytest.raises(ParameterError, match=r"x\.toml: not utf-8 text \(byte 7 is 0xff\)"):
        check_text(bom + b"a = \xff", "x.toml")  # byte 7 of the file (4 of the text)
    with pytest.raises(ParameterError, match=r"not ascii text \(byte 0 is 0xef\)"):
        check_text(bom + b"a", "calib.txt", encoding="ascii")  # only UTF-8 has this mark
