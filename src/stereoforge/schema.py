"""Declarative schemas of settings tables: :class:`Key` and :func:`check_table`.

A :class:`Key` says what one setting takes (type, bounds, choices, array or not, default, doc);
:func:`check_table` checks a whole table against ``{name: Key}`` with the validators of
:mod:`stereoforge.validation`, naming unknown keys and where each key sits. The dataset and the
study configurations (``synth.dataset.config.parse``, ``synth.jobs.study.config``) declare their
keys this way.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from stereoforge.validation import (
    check_choice,
    check_int,
    check_keys,
    check_real,
    check_sequence,
    check_type,
    range_text,
)

__all__ = ["Key", "check_table"]


def _join(*parts: str) -> str:
    return " ".join(p for p in parts if p)


_KINDS = {"bool": "true or false", "int": "an integer", "float": "a number", "str": "a string"}
_PLURAL = {"bool": "booleans", "int": "integers", "float": "numbers", "str": "strings"}


@dataclass(frozen=True)
class Key:
    """Declarative schema of one setting: its type, allowed values, default and doc.

    Parameters
    ----------
    kind : {"bool", "int", "float", "str"}
        ``"int"`` also takes a float with an integral value (TOML ``64.0``); ``"float"`` takes
        ints.
    default : object
        The value when the key is absent; ``None`` makes the key optional (absent = unset).
    lo, hi, lo_open, hi_open : bounds of ``"int"`` and ``"float"`` values.
    odd : bool
        ``"int"`` values must be odd.
    choices : tuple, optional
        The allowed values.
    array : bool
        The value is a non-empty array of such values (checked one by one).
    distinct : bool
        With ``array``, no value twice.
    doc : str
        One line for the reference documentation.

    Examples
    --------
    >>> Key("int", 640, lo=8, hi=8192).check(64.0, "rig.width")
    64
    >>> Key("float", None, lo=0.0, hi=0.5, lo_open=True, array=True).expected()
    'a non-empty array of numbers in (0.0, 0.5]'
    """

    kind: str
    default: Any = None
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    odd: bool = False
    choices: tuple[Any, ...] | None = None
    array: bool = False
    distinct: bool = False
    doc: str = ""

    def __post_init__(self) -> None:
        check_choice(self.kind, "Key.kind", tuple(_KINDS))

    @property
    def optional(self) -> bool:
        """The key may be left unset (its default is ``None``)."""
        return self.default is None

    def _scalar_expected(self, plural: bool = False) -> str:
        if self.choices is not None:
            return f"{'values in' if plural else 'one of'} {list(self.choices)!r}"
        what = (_PLURAL if plural else _KINDS)[self.kind]
        if self.odd:
            what = "odd integers" if plural else "an odd integer"
        if self.kind in ("int", "float"):
            what = _join(what, range_text(self.lo, self.hi, lo_open=self.lo_open,
                                          hi_open=self.hi_open))
        return what

    def expected(self) -> str:
        """What the key takes, in words (``"an integer in [8, 8192]"``)."""
        if self.array:
            return f"a non-empty array of {self._scalar_expected(plural=True)}"
        return self._scalar_expected()

    def check_scalar(self, value: Any, name: str, *, fix: str | None = None,
                     where: str | None = None) -> Any:
        """One value (an entry of an array key, a bound of a distribution) checked and converted."""
        expected = self._scalar_expected()
        if self.kind == "bool":
            return bool(check_type(value, name, (bool, np.bool_), expected=expected, fix=fix,
                                   where=where))
        if self.kind == "str":
            value = check_type(value, name, str, expected=expected, fix=fix, where=where)
        elif self.kind == "int":
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            value = check_int(value, name, lo=self.lo, hi=self.hi, lo_open=self.lo_open,
                              hi_open=self.hi_open, odd=self.odd, fix=fix, where=where)
        else:
            value = check_real(value, name, lo=self.lo, hi=self.hi, lo_open=self.lo_open,
                               hi_open=self.hi_open, fix=fix, where=where)
        if self.choices is not None:
            value = check_choice(value, name, self.choices, fix=fix, where=where)
        return value

    def check(self, value: Any, name: str, *, fix: str | None = None,
              where: str | None = None) -> Any:
        """The value checked and converted (a tuple for an array key)."""
        if not self.array:
            return self.check_scalar(value, name, fix=fix, where=where)
        return check_sequence(value, name, nonempty=True, distinct=self.distinct, noun="array",
                              of=self._scalar_expected(plural=True), fix=fix, where=where,
                              item=lambda v, n: self.check_scalar(v, n, fix=fix, where=where))


def check_table(table: Any, name: str, schema: Mapping[str, Key], *, path: str = "",
                where: Callable[[str], str | None] | None = None, fix: str | None = None,
                skip: Iterable[str] = ()) -> dict[str, Any]:
    """The keys of ``table`` that ``schema`` describes, checked; unknown keys are an error.

    Parameters
    ----------
    table : Mapping
        The values read (a TOML table).
    name : str
        The table in messages (``"[rig]"``, ``"the top-level table"``).
    path : str
        Key path of the table (``"rig"``): a key is named ``path.key`` in messages (``key`` at
        the top level).
    where : callable, optional
        ``where(key)`` gives the location of a key (``"my.toml:5"``) for the message.
    fix : str, optional
        Appended to an unknown key's message.
    skip : iterable of str
        Keys that are allowed but not checked here (sub-tables).

    Returns
    -------
    dict
        ``{key: checked value}`` for the keys present, in schema order.

    Examples
    --------
    >>> check_table({"width": 64}, "[rig]", {"width": Key("int", 640, lo=8)}, path="rig")
    {'width': 64}
    >>> check_table({"width": 4}, "[rig]", {"width": Key("int", 640, lo=8)}, path="rig")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: rig.width: expected an integer >= 8, got 4
    """
    locate = where or (lambda key: None)
    check_type(table, name, Mapping, expected="a table")
    allowed = [*schema, *skip]
    unknown = [key for key in table if key not in allowed]
    check_keys(table, name, allowed, fix=fix, where=locate(unknown[0]) if unknown else None)
    prefix = f"{path}." if path else ""
    return {key: spec.check(table[key], prefix + key, where=locate(key))
            for key, spec in schema.items() if key in table}
