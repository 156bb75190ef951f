"""Middlebury 2014 ``calib.txt``: parse and format.

The file is one ``key=value`` per line::

    cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]
    cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]
    doffs=131.111
    baseline=193.001
    width=2964
    height=1988
    ndisp=280
    isint=0
    vmin=31
    vmax=257

``cam0``/``cam1`` are the 3x3 intrinsic matrices of the left/right camera (pixels), ``doffs`` the
x-difference of their principal points (``cx1 - cx0``), ``baseline`` in millimetres, ``ndisp`` a
conservative disparity search bound, ``vmin``/``vmax`` tight bounds of the ground truth. Depth in
mm is ``baseline * f / (d + doffs)``. Other keys (``isint``, ``dyavg``, ``dymax``) are kept.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from stereoforge.errors import FormatError
from stereoforge.validation import check_text

__all__ = ["CALIB_KEYS", "format_calib", "parse_calib", "read_calib"]

#: Keys in the order the Middlebury 2014 files list them (and :func:`format_calib` writes them).
CALIB_KEYS: tuple[str, ...] = (
    "cam0", "cam1", "doffs", "baseline", "width", "height", "ndisp", "isint", "vmin", "vmax",
    "dyavg", "dymax",
)
_INT_KEYS = frozenset({"width", "height", "ndisp", "isint"})


def _number(text: str, where: str) -> int | float:
    try:
        value = float(text)
    except ValueError:
        raise FormatError(f"{where}: {text[:40]!r} is not a number") from None
    if not np.isfinite(value):
        raise FormatError(f"{where}: {text[:40]!r} is not a finite number; calib.txt holds "
                          "finite numbers only")
    if value.is_integer() and "." not in text and "e" not in text.lower():
        try:
            return int(text)
        except ValueError:  # more digits than Python converts
            raise FormatError(f"{where}: {text[:40]!r}... has too many digits") from None
    return value


def parse_calib(text: str, *, where: str = "calib.txt") -> dict[str, object]:
    """Parse the text of a ``calib.txt``.

    Raises
    ------
    stereoforge.errors.FormatError
        On a line that is not ``key=value``, a value that is not a finite number or a 3x3
        matrix of them, a non-integer ``width``/``height``/``ndisp``/``isint``.

    Returns
    -------
    dict
        ``cam0``/``cam1`` as (3, 3) float64 arrays; ``width``, ``height``, ``ndisp``, ``isint`` as
        ``int``; other numbers as ``int`` when written without a decimal point, else ``float``.

    Examples
    --------
    >>> c = parse_calib("cam0=[2 0 1; 0 2 1; 0 0 1]\\nbaseline=100.5\\nwidth=3")
    >>> c["cam0"][0, 0], c["baseline"], c["width"]
    (np.float64(2.0), 100.5, 3)
    """
    calib: dict[str, object] = {}
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line:
            continue
        here = f"{where}, line {lineno}"
        key, sep, value = line.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key:
            raise FormatError(f"{here}: expected 'key=value', got {line[:60]!r}")
        if value.startswith("["):
            if not value.endswith("]"):
                raise FormatError(f"{here}: unterminated matrix {value[:60]!r}")
            rows = [r.split() for r in value[1:-1].split(";")]
            try:
                matrix = np.array([[float(x) for x in r] for r in rows], dtype=np.float64)
            except ValueError:  # also rows of different lengths
                raise FormatError(f"{here}: non-numeric matrix entry in {value[:60]!r}") from None
            if matrix.shape != (3, 3):
                raise FormatError(f"{here}: expected a 3x3 matrix, got {value[:60]!r}")
            if not np.isfinite(matrix).all():
                raise FormatError(f"{here}: expected finite matrix entries, got {value[:60]!r}")
            calib[key] = matrix
        else:
            number = _number(value, here)
            if key in _INT_KEYS:
                if float(number) != int(number):
                    raise FormatError(f"{here}: {key} must be an integer, got {value[:40]!r}")
                number = int(number)
            calib[key] = number
    return calib


def read_calib(path: str | os.PathLike[str]) -> dict[str, object]:
    """Read a Middlebury 2014 ``calib.txt`` (see :func:`parse_calib`).

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = pathlib.Path(d, "calib.txt")
    ...     _ = p.write_text(format_calib({"cam0": np.eye(3), "ndisp": 64}))
    ...     read_calib(p)["ndisp"]
    64
    """
    path = Path(path)
    from matcher.io.files import read_file

    text = check_text(read_file(path, what="calib.txt", limit=1 << 20), str(path),
                      encoding="ascii", error=FormatError,
                      fix="a calib.txt is ASCII text")
    return parse_calib(text, where=str(path))


def _fmt(value: object) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(int(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    v = float(value)  # type: ignore[arg-type]
    if not np.isfinite(v):
        raise ValueError(f"calib: expected finite numbers, got {v}")
    if v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return np.format_float_positional(v, trim="-")


def format_calib(calib: Mapping[str, object]) -> str:
    """Format a calibration dict as the text of a Middlebury 2014 ``calib.txt``.

    Known keys come first in :data:`CALIB_KEYS` order, others follow in insertion order.
    Matrices are written ``[a b c; d e f; g h i]``; numbers in their shortest exact decimal
    form (integral floats without a decimal point, as Middlebury writes ``vmin=31``).

    Examples
    --------
    >>> import numpy as np
    >>> print(format_calib({"cam0": np.array([[500., 0, 31.5], [0, 500, 23.5], [0, 0, 1]]),
    ...                     "baseline": 100.0, "width": 64}), end="")
    cam0=[500 0 31.5; 0 500 23.5; 0 0 1]
    baseline=100
    width=64
    """
    keys = [k for k in CALIB_KEYS if k in calib] + [k for k in calib if k not in CALIB_KEYS]
    lines = []
    for key in keys:
        if not isinstance(key, str) or not key or "=" in key or "\n" in key:
            raise ValueError(f"calib: invalid key {key!r}")
        value = calib[key]
        if isinstance(value, (np.ndarray, list, tuple)):
            m = np.asarray(value, dtype=np.float64)
            if m.shape != (3, 3):
                raise ValueError(f"calib[{key!r}]: expected a 3x3 matrix, got shape {m.shape}")
            body = "; ".join(" ".join(_fmt(x) for x in row) for row in m)
            lines.append(f"{key}=[{body}]")
        else:
            lines.append(f"{key}={_fmt(value)}")
    return "".join(line + "\n" for line in lines)
