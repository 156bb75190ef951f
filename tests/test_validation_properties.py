"""Properties of the shared validators: accept exactly the values in range, refuse the others
with one message that names the place, the parameter, the bounds and the value."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stereoforge.errors import ParameterError, StereoforgeError
from stereoforge.validation import check_choice, check_int, check_real, range_text

bound = st.one_of(st.none(), st.integers(-50, 50))
wheres = st.one_of(st.none(), st.sampled_from(["my.toml:3", "objects[2].texture"]))


def _inside(v, lo, hi, lo_open, hi_open) -> bool:
    if v != v:
        return False
    return (lo is None or (v > lo if lo_open else v >= lo)) and \
        (hi is None or (v < hi if hi_open else v <= hi))


def _check_message(exc: StereoforgeError, name: str, where: str | None, got: str) -> None:
    text = str(exc)
    head = f"{where}: {name}: expected " if where else f"{name}: expected "
    assert text.startswith(head), text
    assert f", got {got}" in text, text


@given(st.integers(-100, 100), bound, bound, st.booleans(), st.booleans(), wheres)
def test_int_accepts_exactly_the_values_in_range(v, lo, hi, lo_open, hi_open, where):
    kwargs = dict(lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open)
    if _inside(v, **kwargs):
        assert check_int(v, "n", where=where, **kwargs) == v
    else:
        with pytest.raises(ParameterError) as info:
            check_int(v, "n", where=where, **kwargs)
        _check_message(info.value, "n", where, repr(v))
        assert range_text(**kwargs) in str(info.value)


def test_int_range_example():
    with pytest.raises(ParameterError, match=r"^n: expected an integer in \(0, 4\], got 0$"):
        check_int(0, "n", lo=0, hi=4, lo_open=True)


@given(st.one_of(st.floats(-100, 100), st.just(math.inf), st.just(-math.inf), st.just(math.nan)),
       bound, bound, st.booleans(), st.booleans(), st.booleans(), wheres)
def test_real_accepts_exactly_the_values_in_range(v, lo, hi, lo_open, hi_open, finite, where):
    kwargs = dict(lo=lo, hi=hi, lo_open=lo_open, hi_open=hi_open)
    ok = _inside(v, **kwargs) and (math.isfinite(v) or not finite)
    if ok:
        assert check_real(v, "x", finite=finite, where=where, **kwargs) == v
    else:
        with pytest.raises(ParameterError) as info:
            check_real(v, "x", finite=finite, where=where, **kwargs)
        _check_message(info.value, "x", where, repr(float(v)))


def test_real_range_example():
    assert check_real(-math.inf, "x", hi=0, finite=False) == -math.inf
    with pytest.raises(ParameterError, match=r"^x: expected a finite number <= 0, got -inf$"):
        check_real(-math.inf, "x", hi=0)


@given(st.lists(st.sampled_from(["box", "sphere", "plane", 1, 2.5]), min_size=1, unique=True),
       st.sampled_from(["box", "sphere", "cube", 1, 3, True]))
def test_choice_accepts_exactly_its_choices(choices, value):
    member = any(value == c and isinstance(value, bool) == isinstance(c, bool) for c in choices)
    if member:
        assert check_choice(value, "kind", choices) == value
    else:
        with pytest.raises(ParameterError) as info:
            check_choice(value, "kind", choices)
        _check_message(info.value, "kind", None, repr(value))
        assert repr(list(choices)) in str(info.value)


def test_choice_example():
    with pytest.raises(ParameterError, match=r"got True"):  # True == 1, yet not the choice 1
        check_choice(True, "q", [1, 2])
