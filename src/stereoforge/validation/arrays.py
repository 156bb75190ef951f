"""Checks of numpy arrays: type, dtype, shape and finite values, in the message format of
:func:`stereoforge.validation.checks.fail` (:mod:`stereoforge.validation` re-exports them)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from stereoforge.errors import ParameterTypeError
from stereoforge.validation.checks import check_type, fail

__all__ = ["check_array", "check_dtype", "check_shape", "check_finite"]


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
