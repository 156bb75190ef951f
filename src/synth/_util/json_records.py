"""The JSON records stereoforge writes and reads back (``dataset.json``, ``sample.json``, study
cells, the golden manifest), read so that a damaged or foreign file is one clear error.

:func:`read_json_object` turns every way a file can fail to be the record asked for (not UTF-8,
not JSON, nested too deeply, an integer of more digits than Python converts, not an object, a key
missing or of the wrong type) into the caller's error class naming the file and the fix.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from stereoforge.errors import DatasetError, StereoforgeError

__all__ = ["json_bytes", "loads_json_object", "read_json_object"]

_TYPE_NAMES = {dict: "an object", list: "an array", str: "a string", int: "an integer",
               float: "a number", bool: "true or false"}


def _type_ok(value: Any, kind: type) -> bool:
    if kind is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if kind is float:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    return isinstance(value, kind)


def loads_json_object(data: bytes | str, *, where: str, what: str,
                      keys: Mapping[str, type] | None = None, fix: str = "",
                      error: type[StereoforgeError] = DatasetError) -> dict[str, Any]:
    """The JSON object in ``data``, holding at least ``keys`` (name -> type).

    Parameters
    ----------
    data : bytes or str
        The document (bytes are decoded as UTF-8).
    where : str
        The file, for messages.
    what : str
        What the file should be (``"dataset header"``), for messages.
    keys : mapping of str to type, optional
        Required keys and the type of their values (``int`` excludes ``bool``).
    fix : str
        Appended to every message (``"; " + fix``).
    error : type
        The class raised.

    Examples
    --------
    >>> loads_json_object(b'{"index": 3}', where="s.json", what="sample record", keys={"index": int})
    {'index': 3}
    >>> loads_json_object(b'[]', where="s.json", what="sample record")
    Traceback (most recent call last):
    ...
    stereoforge.errors.DatasetError: s.json: not a sample record: expected a JSON object, got an array
    """
    tail = f"; {fix}" if fix else ""
    try:
        text = data.decode("utf-8") if isinstance(data, (bytes, bytearray)) else data
        obj = json.loads(text)
    except UnicodeDecodeError as exc:
        raise error(f"{where}: not a {what}: byte {exc.start} is not UTF-8{tail}") from None
    except RecursionError:
        raise error(f"{where}: not a {what}: JSON nested too deeply{tail}") from None
    except ValueError as exc:  # JSONDecodeError, or an integer of more than 4300 digits
        raise error(f"{where}: not a {what}: invalid JSON ({exc}){tail}") from None
    if not isinstance(obj, dict):
        got = _TYPE_NAMES.get(type(obj), type(obj).__name__)
        if obj is None:
            got = "null"
        raise error(f"{where}: not a {what}: expected a JSON object, got {got}{tail}")
    for key, kind in (keys or {}).items():
        if key not in obj:
            raise error(f"{where}: not a {what}: the key {key!r} is missing{tail}")
        if not _type_ok(obj[key], kind):
            raise error(f"{where}: not a {what}: {key!r} must be {_TYPE_NAMES.get(kind, kind)}, "
                        f"got {type(obj[key]).__name__}{tail}")
    return obj


def read_json_object(path: str | Path, *, what: str, keys: Mapping[str, type] | None = None,
                     fix: str = "", error: type[StereoforgeError] = DatasetError) -> dict[str, Any]:
    """:func:`loads_json_object` of the file ``path`` (an ``OSError`` if it cannot be read)."""
    from matcher.io.files import read_file

    path = Path(path) if isinstance(path, str) else path  # or an fsspec path (dataset.storage.fs)
    data = read_file(path, what=what, limit=1 << 28) if isinstance(path, Path) else path.read_bytes()
    return loads_json_object(data, where=str(path), what=what, keys=keys, fix=fix, error=error)


def json_bytes(obj: Any) -> bytes:
    """``obj`` as the canonical JSON of our records (indented, sorted keys, final newline).

    Examples
    --------
    >>> json_bytes({"b": 1, "a": 2}).decode().splitlines()
    ['{', '  "a": 2,', '  "b": 1', '}']
    """
    return (json.dumps(obj, indent=2, sort_keys=True) + "\n").encode()
