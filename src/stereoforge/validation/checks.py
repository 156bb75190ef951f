"""The message format of every check, and the checks of scalars, choices, sequences, keys, text
and input files (:mod:`stereoforge.validation` re-exports them).

:func:`fail` builds the message ``[<where>: ]<name>: expected <what>, got <what was given>[; fix]``;
:func:`short_repr` and :func:`describe` write the ``got`` part. Most of the length is the doctests
that show each message.
"""

from __future__ import annotations

import codecs
import difflib
import math
import numbers
import os
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from stereoforge.errors import ParameterError, ParameterTypeError, StereoforgeError

__all__ = ["short_repr", "describe", "range_text", "fail", "check_type", "check_bool", "check_int",
           "check_real", "check_choice", "check_sequence", "check_keys", "check_text",
           "check_input_file"]

_MAX_REPR = 80
_BOM = codecs.BOM_UTF8


def short_repr(value: object) -> str:
    """``repr(value)``, cut to :data:`_MAX_REPR` characters."""
    try:
        text = repr(value)
    except ValueError:  # an int of more digits than Python prints (sys.get_int_max_str_digits)
        text = f"<{value.bit_length()}-bit integer>" if isinstance(value, int) else "<?>"
    return text if len(text) <= _MAX_REPR else text[:_MAX_REPR - 3] + "..."


def describe(value: object) -> str:
    """The type and value of ``value`` for an error message (arrays by shape and dtype).

    Examples
    --------
    >>> describe(1.5), describe(np.zeros((2, 3), np.uint8))
    ('float 1.5', 'array of shape (2, 3) and dtype uint8')
    """
    if isinstance(value, np.ndarray):
        return f"array of shape {value.shape} and dtype {value.dtype}"
    return f"{type(value).__name__} {short_repr(value)}"


def range_text(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
               hi_open: bool = False) -> str:
    """``"in [lo, hi)"``, ``">= lo"``, ``"< hi"`` ... or ``""`` without bounds.

    Examples
    --------
    >>> range_text(0, 4, lo_open=True), range_text(0.0), range_text(hi=1, hi_open=True)
    ('in (0, 4]', '>= 0.0', '< 1')
    """
    if lo is not None and hi is not None:
        return f"in {'(' if lo_open else '['}{lo!r}, {hi!r}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {lo!r}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {hi!r}"
    return ""


def _in_range(v: float, lo: float | None, hi: float | None, lo_open: bool, hi_open: bool) -> bool:
    """``v`` within the bounds (NaN never is)."""
    ok = v == v
    if lo is not None:
        ok = ok and (v > lo if lo_open else v >= lo)
    if hi is not None:
        ok = ok and (v < hi if hi_open else v <= hi)
    return ok


def _join(*parts: str) -> str:
    return " ".join(p for p in parts if p)


def fail(name: str, expected: str, actual: str, *, fix: str | None = None,
         where: str | None = None, error: type[StereoforgeError] = ParameterError
         ) -> StereoforgeError:
    """The error for ``name``: ``[where: ]name: expected <expected>, got <actual>[; fix]``.

    Returns the exception (``raise fail(...)``) so a check of one's own reads like the others.

    Examples
    --------
    >>> str(fail("near, far", "0 < near < far", "near=5.0, far=2.0", fix="swap them"))
    'near, far: expected 0 < near < far, got near=5.0, far=2.0; swap them'
    """
    head = f"{where}: " if where else ""
    tail = f"; {fix}" if fix else ""
    return error(f"{head}{name}: expected {expected}, got {actual}{tail}")


def _article(cls: type) -> str:
    name = cls.__name__
    return f"{'an' if name[:1].lower() in 'aeiou' else 'a'} {name}"


def check_type(value: Any, name: str, types: type | tuple[type, ...], *,
               expected: str | None = None, fix: str | None = None,
               where: str | None = None) -> Any:
    """``value`` if it is an instance of ``types``, else :class:`ParameterTypeError`.

    Examples
    --------
    >>> check_type((0, 0, 0), "pose", dict)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterTypeError: pose: expected a dict, got tuple (0, 0, 0)
    """
    if not isinstance(value, types):
        if expected is None:
            classes = types if isinstance(types, tuple) else (types,)
            expected = " or ".join(_article(c) for c in classes)
        raise fail(name, expected, describe(value), fix=fix, where=where,
                   error=ParameterTypeError)
    return value


def check_bool(value: Any, name: str, *, where: str | None = None) -> bool:
    """``True`` or ``False`` (numpy's too), never an int standing for one.

    Examples
    --------
    >>> check_bool(np.True_, "lr_check")
    True
    >>> check_bool(1, "lr_check")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterTypeError: lr_check: expected True or False, got int 1
    """
    return bool(check_type(value, name, (bool, np.bool_), expected="True or False", where=where))


def _is_int(value: Any) -> bool:
    # the exact built-in type first: the ABC check costs ~1 us per call (bool is not int's type)
    return type(value) is int or (isinstance(value, numbers.Integral)
                                  and not isinstance(value, (bool, np.bool_)))


def _is_real(value: Any) -> bool:
    return type(value) in (float, int) or (isinstance(value, numbers.Real)
                                           and not isinstance(value, (bool, np.bool_)))


def _check_number(value: Any, name: str, what: str, accepts: Callable[[Any], bool],
                  convert: Callable[[Any], Any], valid: Callable[[Any], bool],
                  bounds: tuple[Any, Any, bool, bool], fix: str | None, where: str | None) -> Any:
    """``convert(value)`` if ``accepts(value)`` (else a type error), ``valid`` and in ``bounds``.

    The message's text is made only on failure: a scene's specs run these checks hundreds of
    times per sample."""
    lo, hi, lo_open, hi_open = bounds

    def expected() -> str:
        return _join(what, range_text(lo, hi, lo_open=lo_open, hi_open=hi_open))

    if not accepts(value):
        raise fail(name, expected(), describe(value), fix=fix, where=where,
                   error=ParameterTypeError)
    try:
        v = convert(value)
    except OverflowError:  # an integer beyond the float range (10**400 read from JSON)
        raise fail(name, expected(), describe(value), fix=fix, where=where) from None
    if not (valid(v) and _in_range(v, lo, hi, lo_open, hi_open)):
        raise fail(name, expected(), short_repr(v), fix=fix, where=where)
    return v


def check_int(value: Any, name: str, *, lo: int | None = None, hi: int | None = None,
              lo_open: bool = False, hi_open: bool = False, odd: bool = False,
              fix: str | None = None, where: str | None = None) -> int:
    """An integer (Python or numpy, not a bool) within the bounds, as ``int``.

    Examples
    --------
    >>> check_int(np.int64(3), "seed", lo=0)
    3
    >>> check_int(1.0, "seed", lo=0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterTypeError: seed: expected an integer >= 0, got float 1.0
    """
    return _check_number(value, name, "an odd integer" if odd else "an integer", _is_int, int,
                         lambda v: not odd or v % 2 == 1, (lo, hi, lo_open, hi_open), fix, where)


def check_real(value: Any, name: str, *, lo: float | None = None, hi: float | None = None,
               lo_open: bool = False, hi_open: bool = False, finite: bool = True,
               fix: str | None = None, where: str | None = None) -> float:
    """A real number (int, float or numpy scalar, not a bool) within the bounds, as ``float``.

    ``finite=False`` lets ``inf`` through (bounds permitting); NaN never passes.

    Examples
    --------
    >>> check_real(2, "gain", lo=0, hi=4, lo_open=True)
    2.0
    >>> check_real(float("nan"), "mean", lo=0.0, hi=1.0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: mean: expected a finite number in [0.0, 1.0], got nan
    """
    return _check_number(value, name, "a finite number" if finite else "a number", _is_real,
                         float, lambda v: not finite or math.isfinite(v),
                         (lo, hi, lo_open, hi_open), fix, where)


def _same(value: Any, choice: Any) -> bool:
    if isinstance(value, (bool, np.bool_)) != isinstance(choice, (bool, np.bool_)):
        return False  # True is not the choice 1
    try:
        return bool(value == choice)
    except (TypeError, ValueError):  # e.g. an array compared elementwise
        return False


def _suggest(value: Any, names: Iterable[Any]) -> str | None:
    """``"did you mean 'x'?"`` for a mistyped string, else ``None``."""
    if not isinstance(value, str):
        return None
    close = difflib.get_close_matches(value, [n for n in names if isinstance(n, str)], n=1)
    return f"did you mean {close[0]!r}?" if close else None


def _join_fix(*fixes: str | None) -> str | None:
    return "; ".join(f for f in fixes if f) or None


def check_choice(value: Any, name: str, choices: Iterable[Any], *, fix: str | None = None,
                 where: str | None = None) -> Any:
    """``value`` if it equals one of ``choices`` (a mistyped string gets a suggestion).

    Examples
    --------
    >>> check_choice("bx", "occluder_kind", ("box", "sphere"))
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: occluder_kind: expected one of ['box', 'sphere'], got 'bx'; did you mean 'box'?
    """
    choices = list(choices)
    if any(_same(value, c) for c in choices):
        return value
    raise fail(name, f"one of {choices!r}", repr(value),
               fix=_join_fix(_suggest(value, choices), fix), where=where)


def check_sequence(value: Any, name: str, *, length: int | None = None, nonempty: bool = False,
                   distinct: bool = False, item: Callable[[Any, str], Any] | None = None,
                   of: str = "values", noun: str = "sequence", fix: str | None = None,
                   where: str | None = None) -> tuple[Any, ...]:
    """A list, tuple or 1-D array as a tuple, each entry checked by ``item(entry, "name[i]")``.

    Parameters
    ----------
    length : int, optional
        Required number of entries.
    nonempty, distinct : bool
        Require at least one entry; forbid an entry twice.
    item : callable, optional
        ``item(entry, name)`` validates and converts one entry, e.g.
        ``lambda v, n: check_real(v, n, lo=0.0)``.
    of, noun : str
        Words of the message: ``"a sequence of 3 numbers"``, ``"a non-empty array of integers"``.

    Examples
    --------
    >>> check_sequence([1, 2], "color", length=3, of="numbers")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: color: expected a sequence of 3 numbers, got 2 entries (1, 2)
    """
    size = f"{length} " if length is not None else ""
    if length == 1 and of.endswith("s"):
        of = of[:-1]  # "a sequence of 1 number"
    expected = f"{'a non-empty ' if nonempty else 'a '}{noun} of {size}{of}"
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__") \
            or not hasattr(value, "__iter__") or (isinstance(value, np.ndarray) and value.ndim != 1):
        raise fail(name, expected, describe(value), fix=fix, where=where,
                   error=ParameterTypeError)
    entries = tuple(value)
    if (length is not None and len(entries) != length) or (nonempty and not entries):
        raise fail(name, expected, f"{len(entries)} entries {entries!r}", fix=fix, where=where)
    if item is not None:
        entries = tuple(item(v, f"{name}[{i}]") for i, v in enumerate(entries))
    if distinct:
        seen: list[Any] = []
        for v in entries:
            if any(_same(v, s) for s in seen):
                raise fail(name, f"distinct {of}", f"{v!r} twice in {list(entries)!r}",
                           fix=_join_fix(f"remove the repeated {v!r}", fix), where=where)
            seen.append(v)
    return entries




def check_keys(mapping: Mapping[Any, Any], name: str, allowed: Iterable[Any], *,
               fix: str | None = None, where: str | None = None,
               error: type[StereoforgeError] = ParameterError) -> Mapping[Any, Any]:
    """``mapping`` if every key is in ``allowed``; else name the first unknown key, the valid
    keys and the closest one.

    Examples
    --------
    >>> check_keys({"gian": 1.0}, "PhotometricParams", ["gain", "bias"])
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: unknown key 'gian' in PhotometricParams; valid keys: ['gain', 'bias']; did you mean 'gain'?
    """
    allowed = list(allowed)
    for key in mapping:
        if key not in allowed:
            head = f"{where}: " if where else ""
            tail = _join_fix(_suggest(key, allowed), fix)
            raise error(f"{head}unknown key {key!r} in {name}; valid keys: {allowed!r}"
                        + (f"; {tail}" if tail else ""))
    return mapping


def check_text(data: bytes, name: str, *, encoding: str = "utf-8", fix: str | None = None,
               error: type[StereoforgeError] = ParameterError) -> str:
    """The bytes of a text file, decoded; else an ``error`` naming ``name`` and the first bad
    byte.

    A UTF-8 byte-order mark at the start (what some Windows editors write) is dropped: it is
    on line 1 before column 1, so lines and columns of the text stay those an editor shows,
    and the bad byte of an error is counted in the file's bytes, mark included.

    Examples
    --------
    >>> check_text(b"a = 1", "my.toml")
    'a = 1'
    >>> check_text(b"\\xef\\xbb\\xbfa = 1", "my.toml")
    'a = 1'
    >>> check_text(b"a = \\xff", "my.toml", fix="save it as UTF-8")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: my.toml: not utf-8 text (byte 4 is 0xff); save it as UTF-8
    """
    start = len(_BOM) if codecs.lookup(encoding).name == "utf-8" and data.startswith(_BOM) else 0
    try:
        return data[start:].decode(encoding)
    except UnicodeDecodeError as exc:
        tail = f"; {fix}" if fix else ""
        at = start + exc.start
        raise error(f"{name}: not {encoding} text (byte {at} is {data[at]:#04x}){tail}") from None


def check_input_file(path: str | os.PathLike[str], what: str, *, suffixes: Iterable[str] = (),
                     fix: str | None = None) -> Path:
    """``path`` as a :class:`~pathlib.Path` when it is a file to read; else an error naming
    ``what``: :class:`FileNotFoundError` (nothing there) or :class:`IsADirectoryError` (a
    directory, with the files of ``suffixes`` it holds, a few at most, as the way out).

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "a.toml").write_text("")
    >>> check_input_file(d / "a.toml", "dataset config").name
    'a.toml'
    >>> check_input_file(d, "dataset config", suffixes=[".toml"], fix="pass a .toml file")
    Traceback (most recent call last):
    ...
    IsADirectoryError: dataset config ... is a directory (holding a.toml); pass a .toml file
    >>> check_input_file(d / "b.toml", "dataset config")
    Traceback (most recent call last):
    ...
    FileNotFoundError: dataset config .../b.toml does not exist
    """
    path = Path(path)
    if path.is_file():
        return path
    tail = f"; {fix}" if fix else ""
    if path.is_dir():
        wanted = {s.lower() for s in suffixes}
        inside = sorted(p.name for p in path.iterdir() if p.suffix.lower() in wanted and p.is_file())
        holding = f" (holding {', '.join(inside[:3])}{', ...' if len(inside) > 3 else ''})" \
            if inside else ""
        raise IsADirectoryError(f"{what} {path} is a directory{holding}{tail}")
    raise FileNotFoundError(f"{what} {path} does not exist{tail}")
