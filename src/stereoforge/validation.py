"""One way to check input: small validators with one message format.

Every check takes the value and the parameter's name (and optionally ``where``: a ``file:line``,
a configuration key path or an object such as ``objects[2]``), returns the value converted to a
plain Python or numpy type, and on bad input raises :class:`~stereoforge.errors.ParameterError`
(a ``ValueError``) or, for a wrong type or dtype, :class:`~stereoforge.errors.ParameterTypeError`
(a ``TypeError``) whose message reads::

    [<where>: ]<name>: expected <what is allowed>, got <what was given>[; <the fix>]

:func:`fail` builds that message for checks of one's own (a relation between two parameters,
say), so every error reads the same. :mod:`stereoforge.schema` builds on these to describe and
check a whole table of settings (the dataset and study configurations).

One idea, one module: the checks and their message format; most of its length is the doctests
that show each message.

Examples
--------
>>> check_real(0.5, "contrast", lo=0.0, hi=1.0)
0.5
>>> check_int(4, "window", lo=3, odd=True)
Traceback (most recent call last):
...
stereoforge.errors.ParameterError: window: expected an odd integer >= 3, got 4
>>> check_choice("perlin", "kind", ("noise", "checker"), where="objects[0].texture")
Traceback (most recent call last):
...
stereoforge.errors.ParameterError: objects[0].texture: kind: expected one of ['noise', 'checker'], got 'perlin'

One module on purpose: the validators share one message format, which is the point of having them.
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

__all__ = [
    "describe",
    "range_text",
    "fail",
    "check_type",
    "check_bool",
    "check_int",
    "check_real",
    "check_rotation_deg",
    "check_distortion",
    "check_choice",
    "check_sequence",
    "check_array",
    "check_dtype",
    "check_shape",
    "check_finite",
    "check_keys",
    "check_text",
    "check_input_file",
]

_MAX_REPR = 80
_BOM = codecs.BOM_UTF8


def _short(value: object) -> str:
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
    return f"{type(value).__name__} {_short(value)}"


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
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _check_number(value: Any, name: str, what: str, accepts: Callable[[Any], bool],
                  convert: Callable[[Any], Any], valid: Callable[[Any], bool],
                  bounds: tuple[Any, Any, bool, bool], fix: str | None, where: str | None) -> Any:
    """``convert(value)`` if ``accepts(value)`` (else a type error), ``valid`` and in ``bounds``."""
    lo, hi, lo_open, hi_open = bounds
    expected = _join(what, range_text(lo, hi, lo_open=lo_open, hi_open=hi_open))
    if not accepts(value):
        raise fail(name, expected, describe(value), fix=fix, where=where,
                   error=ParameterTypeError)
    try:
        v = convert(value)
    except OverflowError:  # an integer beyond the float range (10**400 read from JSON)
        raise fail(name, expected, describe(value), fix=fix, where=where) from None
    if not (valid(v) and _in_range(v, lo, hi, lo_open, hi_open)):
        raise fail(name, expected, _short(v), fix=fix, where=where)
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


def check_array(value: Any, name: str, *, fix: str | None = "convert with np.asarray",
                where: str | None = None) -> np.ndarray:
    """``value`` if it is a numpy array (no silent conversion of lists).

    Examples
    --------
    >>> check_array([[1, 2]], "left")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterTypeError: left: expected a numpy array, got list [[1, 2]]; convert with np.asarray
    """
    return check_type(value, name, np.ndarray, expected="a numpy array", fix=fix, where=where)


def check_dtype(array: np.ndarray, name: str, *, kinds: str = "",
                dtypes: Iterable[Any] = (), expected: str | None = None,
                fix: str | None = None, where: str | None = None) -> np.ndarray:
    """``array`` if its dtype is one of ``dtypes`` or of a kind in ``kinds`` (``"uif"``: integers
    and floats; bool is kind ``"b"``).

    Examples
    --------
    >>> check_dtype(np.zeros(2, bool), "image", kinds="uif", expected="an integer or float image")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterTypeError: image: expected an integer or float image, got dtype bool
    """
    allowed = [np.dtype(d) for d in dtypes]
    if array.dtype.kind in kinds or array.dtype in allowed:
        return array
    if expected is None:
        expected = "dtype " + " or ".join([*(str(d) for d in allowed), *(f"kind {k!r}" for k in kinds)])
    raise fail(name, expected, f"dtype {array.dtype}", fix=fix, where=where,
               error=ParameterTypeError)


def check_shape(array: np.ndarray, name: str, shape: Iterable[int | str | None], *,
                fix: str | None = None, where: str | None = None) -> np.ndarray:
    """``array`` if its shape matches ``shape``: an int fixes a side, a str (``"H"``) or ``None``
    lets it be any size.

    Examples
    --------
    >>> check_shape(np.zeros((2, 2)), "d", (3, 3))
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: d: expected shape (3, 3), got (2, 2)
    >>> check_shape(np.zeros(4), "image", ("H", "W"))
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: image: expected shape (H, W), got (4,)
    """
    want = tuple(shape)
    ok = len(want) == array.ndim and all(
        w is None or isinstance(w, str) or int(w) == s for w, s in zip(want, array.shape))
    if not ok:
        text = "(" + ", ".join("?" if w is None else str(w) for w in want) + ("," if len(want) == 1 else "") + ")"
        raise fail(name, f"shape {text}", str(array.shape), fix=fix, where=where)
    return array


def check_finite(array: np.ndarray, name: str, *, what: str = "values", fix: str | None = None,
                 where: str | None = None) -> np.ndarray:
    """``array`` if it holds no NaN or inf.

    Examples
    --------
    >>> check_finite(np.array([0.0, np.nan]), "right", what="pixel values")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: right: expected finite pixel values, got 1 NaN/inf (of 2)
    """
    bad = ~np.isfinite(array)
    if bad.any():
        raise fail(name, f"finite {what}", f"{int(bad.sum())} NaN/inf (of {array.size})",
                   fix=fix, where=where)
    return array


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


def check_rotation_deg(value: Any, name: str, *, limit: float, where: str | None = None) -> float:
    """An angle in degrees within ``[-limit, limit]`` (a small rotation), as ``float``.

    Examples
    --------
    >>> check_rotation_deg(30, "rx", limit=10.0)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: rx: expected a rotation within +-10.0 degrees, got 30.0; a rectification error is a small rotation: pass degrees, not radians, and at most 10.0
    """
    v = check_real(value, name, where=where)
    if not abs(v) <= limit:
        raise fail(name, f"a rotation within +-{limit} degrees", _short(v), where=where,
                   fix=f"a rectification error is a small rotation: pass degrees, not radians, "
                       f"and at most {limit}")
    return v


#: Largest tangential coefficient ``|p1|``, ``|p2|`` of :func:`check_distortion`.
MAX_TANGENTIAL = 0.05


def check_distortion(coeffs: Any, name: str, *, max_radius: float,
                     where: str | None = None) -> tuple[float, ...]:
    """OpenCV ``(k1, k2, p1, p2, k3)`` that map the image one-to-one, as a tuple of floats.

    The radial mapping ``g(r) = r (1 + k1 r^2 + k2 r^4 + k3 r^6)`` (normalised units) must
    increase from the centre up to ``max_radius``, the distorted radius of the image's farthest
    corner: with ``r_f`` the first radius where ``g'(r) = 0``, the bound is ``g(r_f) >
    max_radius``. ``|p1|, |p2| <= 0.05``, and the Jacobian of the whole mapping (tangential terms
    included) must stay positive on the image (checked on a polar grid of 64 x 64 points).

    Examples
    --------
    >>> check_distortion((-0.3, 0.0, 0.0, 0.0, 0.0), "k", max_radius=0.7)
    (-0.3, 0.0, 0.0, 0.0, 0.0)
    >>> check_distortion((-0.6, 0.0, 0.0, 0.0, 0.0), "k", max_radius=0.7)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: k: expected a distortion that does not fold the image: ...
    """
    c = tuple(check_real(v, f"{name}[{i}]", where=where)
              for i, v in enumerate(check_sequence(coeffs, name, length=5, where=where)))
    k1, k2, p1, p2, k3 = c
    r_max = check_real(max_radius, "max_radius", lo=0, lo_open=True)
    for label, p in (("p1", p1), ("p2", p2)):
        if not abs(p) <= MAX_TANGENTIAL:
            raise fail(f"{name} {label}", f"|{label}| <= {MAX_TANGENTIAL}", _short(p), where=where,
                       fix="real lenses have tangential coefficients of about 1e-3")
    # first positive root of g'(r) = 1 + 3 k1 s + 5 k2 s^2 + 7 k3 s^3 (s = r^2)
    roots = np.roots([7.0 * k3, 5.0 * k2, 3.0 * k1, 1.0]) if any((k1, k2, k3)) else []
    real = [float(s.real) for s in np.atleast_1d(roots)
            if abs(s.imag) <= 1e-12 * max(1.0, abs(s)) and s.real > 0]
    coef = f"k1={k1}, k2={k2}, k3={k3}"

    def g(r: float) -> float:
        with np.errstate(over="ignore", invalid="ignore"):
            s = np.float64(r) * r
            return float(r * (1.0 + s * (k1 + s * (k2 + s * k3))))

    r_f = math.sqrt(min(real)) if real else math.inf
    if real and not g(r_f) > r_max:
        raise fail(name, "a distortion that does not fold the image: the radial mapping "
                   "r (1 + k1 r^2 + k2 r^4 + k3 r^6) must increase up to the image corner's "
                   f"distorted radius {r_max:.4g}", f"{coef}, which stops increasing at "
                   f"r = {r_f:.4g} (distorted radius {g(r_f):.4g})", where=where,
                   fix="reduce |k1|, |k2|, |k3| until that radius exceeds the corner's")
    r_hi = min(1.0, r_f)  # the undistorted radius the image reaches (a little beyond)
    while r_hi < r_f and g(r_hi) < 1.05 * r_max:
        r_hi = min(2.0 * r_hi, r_f)
    if p1 or p2:  # the Jacobian of the full mapping on the undistorted image (up to r_hi)
        r, t = np.meshgrid(np.linspace(0.0, r_hi, 64), np.linspace(0.0, 2 * np.pi, 64))
        x, y = r * np.cos(t), r * np.sin(t)
        r2 = x * x + y * y
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        radius = r * radial
        dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        a = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x
        b = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y
        d = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x
        inside = radius <= r_max * 1.05
        if not np.all((a * d - b * b)[inside] > 0):
            raise fail(name, "a distortion that does not fold the image (a positive Jacobian)",
                       f"p1={p1}, p2={p2} with {coef}, which fold it", where=where,
                       fix="reduce |p1|, |p2|")
    return c
