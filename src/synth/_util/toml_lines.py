"""Where each key of a TOML document sits: the ``file:line`` of configuration errors.

:func:`key_lines` reads the text with a small scanner that knows what TOML can hide a ``[`` or
a ``=`` in: basic and literal strings, multi-line ones (``\"\"\"`` and ``'''``), comments; and
what a key can be: bare, quoted, dotted, inside a table ``[a.b]``, an array of tables
``[[a]]`` (the element's index is part of the path), an inline table ``{k = v}`` or an array
(each element's index). It maps every key path to the line of the key. No TOML parser on PyPI
that keeps positions is maintained (tomlkit keeps none), and tomllib checks the syntax first,
so the scanner only has to find things, not to judge them.

:class:`TomlSource` pairs the text with its file name and checks tables against a
:class:`stereoforge.schema.Key` schema, turning every failure into the configuration's
error class with ``file:line`` in front.
"""

from __future__ import annotations

import bisect
import tomllib
from collections.abc import Callable, Mapping
from typing import Any

from stereoforge.errors import ConfigError, StereoforgeError
from stereoforge.schema import Key, check_table
from stereoforge.validation import check_text, describe, fail

__all__ = ["key_lines", "line_of", "TomlSource", "parse_toml", "read_toml_text"]

Path = tuple[str | int, ...]
_BARE = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-")
_SPACE = " \t"
_SCALAR_END = frozenset(",]}\n#")


class _Scanner:
    """One pass over TOML text recording the line of every key path."""

    def __init__(self, text: str) -> None:
        self.text, self.i, self.n = text, 0, len(text)
        self._newlines = [k for k, c in enumerate(text) if c == "\n"]
        self.lines: dict[Path, int] = {}
        self._arrays: dict[Path, int] = {}  # array-of-tables path -> number of elements so far

    # ------------------------------------------------------------------ helpers
    def line(self, pos: int) -> int:
        return bisect.bisect_left(self._newlines, pos) + 1

    def peek(self, k: int = 0) -> str:
        j = self.i + k
        return self.text[j] if j < self.n else ""

    def skip_space(self) -> None:
        while self.i < self.n and self.text[self.i] in _SPACE:
            self.i += 1

    def skip_blank(self) -> None:
        """Spaces, newlines and comments."""
        while self.i < self.n:
            c = self.text[self.i]
            if c in " \t\r\n":
                self.i += 1
            elif c == "#":
                end = self.text.find("\n", self.i)
                self.i = self.n if end < 0 else end
            else:
                return

    def record(self, path: Path, line: int, *, implicit: bool = False) -> None:
        if implicit:
            self.lines.setdefault(path, line)
        else:
            self.lines[path] = line

    # ------------------------------------------------------------------ strings and keys
    def string(self) -> str:
        """Skip the string at ``i`` and return its raw text (quotes included)."""
        start, q = self.i, self.text[self.i]
        if self.text.startswith(q * 3, self.i):  # multi-line: ends at a run of >= 3 quotes
            self.i += 3
            while self.i < self.n:
                c = self.text[self.i]
                if c == "\\" and q == '"':
                    self.i += 2
                elif c == q:
                    run = 0
                    while self.peek(run) == q:
                        run += 1
                    self.i += run
                    if run >= 3:
                        break
                else:
                    self.i += 1
        else:
            self.i += 1
            while self.i < self.n and self.text[self.i] not in (q, "\n"):
                self.i += 2 if self.text[self.i] == "\\" and q == '"' else 1
            self.i += 1
        self.i = min(self.i, self.n)
        return self.text[start:self.i]

    def key(self) -> tuple[str, ...]:
        """A dotted key at ``i`` as its parts (quoted parts decoded)."""
        parts: list[str] = []
        while True:
            self.skip_space()
            c = self.peek()
            if c in ('"', "'"):
                raw = self.string()
                try:
                    parts.append(next(iter(tomllib.loads(f"{raw} = 0"))))
                except (tomllib.TOMLDecodeError, StopIteration):
                    parts.append(raw[1:-1])
            else:
                start = self.i
                while self.i < self.n and self.text[self.i] in _BARE:
                    self.i += 1
                if self.i == start:  # not a key: let the caller move on
                    return tuple(parts)
                parts.append(self.text[start:self.i])
            self.skip_space()
            if self.peek() != ".":
                return tuple(parts)
            self.i += 1

    # ------------------------------------------------------------------ values
    def value(self, path: Path) -> None:
        c = self.peek()
        if c in ('"', "'"):
            self.string()
        elif c == "[":
            self.array(path)
        elif c == "{":
            self.inline_table(path)
        else:  # number, bool, date-time (which may hold a space): up to a delimiter
            start = self.i
            while self.i < self.n and self.text[self.i] not in _SCALAR_END:
                self.i += 1
            if self.i == start and self.i < self.n:
                self.i += 1  # never stall

    def items(self, close: str, each: Callable[[int], None]) -> None:
        """The comma-separated items after an opening bracket, up to ``close``."""
        self.i += 1
        index = 0
        while True:
            self.skip_blank()
            c = self.peek()
            if c in ("", close):
                self.i += 1 if c else 0
                return
            if c == ",":
                self.i += 1
                continue
            each(index)
            index += 1

    def array(self, path: Path) -> None:
        def element(index: int) -> None:
            self.record((*path, index), self.line(self.i))
            self.value((*path, index))

        self.items("]", element)

    def inline_table(self, path: Path) -> None:
        self.items("}", lambda index: self.key_value(path))

    def key_value(self, prefix: Path) -> None:
        line = self.line(self.i)
        parts = self.key()
        if not parts:  # stray character: step over it
            self.i += 1
            return
        for k in range(1, len(parts)):
            self.record((*prefix, *parts[:k]), line, implicit=True)
        path = (*prefix, *parts)
        self.record(path, line)
        self.skip_space()
        if self.peek() == "=":
            self.i += 1
            self.skip_space()
            self.value(path)

    # ------------------------------------------------------------------ tables
    def resolve(self, parts: tuple[str, ...]) -> Path:
        """A header's path, with the current index after every array of tables in it."""
        out: Path = ()
        for p in parts:
            out = (*out, p)
            if out in self._arrays:
                out = (*out, self._arrays[out] - 1)
        return out

    def header(self) -> Path:
        line = self.line(self.i)
        double = self.text.startswith("[[", self.i)
        self.i += 2 if double else 1
        parts = self.key()
        self.skip_space()
        self.i += 2 if double else 1
        if not parts:
            return ()
        parent = self.resolve(parts[:-1])
        for k in range(1, len(parent) + 1):
            self.record(parent[:k], line, implicit=True)
        path = (*parent, parts[-1])
        if double:
            index = self._arrays.get(path, 0)
            self._arrays[path] = index + 1
            self.record(path, line, implicit=True)
            path = (*path, index)
        self.record(path, line)
        return path

    def run(self) -> dict[Path, int]:
        prefix: Path = ()
        while True:
            self.skip_blank()
            if self.i >= self.n:
                return self.lines
            if self.peek() == "[":
                prefix = self.header()
            else:
                self.key_value(prefix)


def key_lines(text: str) -> dict[Path, int]:
    """The 1-based line of every key path of a TOML document.

    A path is the tuple of keys from the top (``("scene", "occluders")``); an element of an
    array, or of an array of tables, adds its index (``("objects", 1, "kind")``). Tables map to
    their header's line (or, when only implied by a dotted key, to that key's line).

    Examples
    --------
    >>> key_lines("a = '''\\n[scene]\\n'''\\n[scene]\\nx = {y = 1}\\n")[("scene", "x", "y")]
    5
    """
    return _Scanner(text).run()


def line_of(text: str, *path: str | int) -> int | None:
    """1-based line of the key at ``path``, else of its nearest enclosing table, else ``None``.

    Examples
    --------
    >>> line_of("[rig]\\nwidth = 4\\n", "rig", "width"), line_of("[rig]\\n", "rig", "far")
    (2, 1)
    """
    lines = key_lines(text)
    for k in range(len(path), 0, -1):
        if path[:k] in lines:
            return lines[path[:k]]
    return None


def parse_toml(text: Any, source: str, error: type[ConfigError] = ConfigError) -> dict[str, Any]:
    """``tomllib.loads(text)``, every failure of the parser raised as ``error`` naming ``source``.

    Examples
    --------
    >>> parse_toml("a = [[[1]]]", "x.toml")
    {'a': [[[1]]]}
    >>> parse_toml("a = " + "[" * 50000, "x.toml")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ConfigError: x.toml: invalid TOML: nested too deeply for this parser
    """
    if not isinstance(text, str):
        raise error(f"{source}: expected TOML text (str), got {type(text).__name__}")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{source}: invalid TOML: {exc}") from None
    except RecursionError:
        raise error(f"{source}: invalid TOML: nested too deeply for this parser") from None


def read_toml_text(path: Any, error: type[ConfigError] = ConfigError) -> str:
    """The text of the TOML file ``path``; a file that is not UTF-8 raises ``error``."""
    with open(path, "rb") as f:
        data = f.read()
    return check_text(data, str(path), fix="TOML files are UTF-8: save it as UTF-8", error=error)


class TomlSource:
    """TOML text and its file name: the ``file:line`` of every error about it.

    Parameters
    ----------
    text : str
        The document (``""`` when the values come from elsewhere, e.g. a dict: then errors
        name ``source`` alone).
    source : str
        File name for messages.
    error : type
        The exception raised (a :class:`~stereoforge.errors.ConfigError` subclass).
    """

    def __init__(self, text: str, source: str, error: type[ConfigError] = ConfigError) -> None:
        self.text, self.source, self.error = text, source, error
        self._lines: dict[Path, int] | None = None

    def where(self, *path: str | int) -> str:
        """``"file:line"`` of ``path`` (its nearest known enclosing table), else ``"file"``."""
        if self._lines is None:
            try:
                self._lines = key_lines(self.text) if self.text else {}
            except RecursionError:  # nested deeper than the scanner follows: name the file
                self._lines = {}
        for k in range(len(path), 0, -1):
            if path[:k] in self._lines:
                return f"{self.source}:{self._lines[path[:k]]}"
        return self.source

    def fail(self, path: tuple[str, ...], expected: str, actual: str, *,
             fix: str | None = None) -> ConfigError:
        """The error for the key at ``path`` (see :func:`stereoforge.validation.fail`)."""
        return fail(".".join(path), expected, actual, fix=fix, where=self.where(*path),
                    error=self.error)

    def convert(self, exc: StereoforgeError) -> ConfigError:
        """A validator's error as this configuration's error (same message)."""
        return exc if isinstance(exc, self.error) else self.error(str(exc))

    def check(self, key: Key, value: Any, path: tuple[str, ...], *, fix: str | None = None,
              scalar: bool = False) -> Any:
        """``key.check(value)`` (``key.check_scalar`` with ``scalar``) named ``a.b`` at its line."""
        try:
            run = key.check_scalar if scalar else key.check
            return run(value, ".".join(path), fix=fix, where=self.where(*path))
        except StereoforgeError as exc:
            raise self.convert(exc) from None

    def table(self, data: Mapping[str, Any], path: tuple[str, ...], schema: Mapping[str, Key],
              *, skip: tuple[str, ...] = (), fix: str | None = None) -> dict[str, Any]:
        """The table at ``path`` checked against ``schema`` (see :func:`check_table`)."""
        name = f"[{'.'.join(path)}]" if path else "the top-level table"
        if not isinstance(data, Mapping):
            raise self.fail(path, f"a table {name}", describe(data))
        try:
            return check_table(data, name, schema, path=".".join(path), skip=skip, fix=fix,
                               where=lambda key: self.where(*path, key))
        except StereoforgeError as exc:
            raise self.convert(exc) from None
