"""The error vocabulary of MATCHER strings (:mod:`matcher.adapters`).

:class:`MatcherError` is a string that does not resolve (raised before any pair is matched);
:class:`MatcherFailure` a matcher that crashed, timed out or returned something that is not a
disparity map on one pair. :func:`one_line` and :func:`describe` make the one-line messages both
carry.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from stereoforge.errors import ParameterError, StereoforgeError

__all__ = ["MatcherError", "MatcherFailure", "describe", "one_line"]


class MatcherError(ParameterError):
    """A MATCHER string does not resolve; the message says what was tried."""


class MatcherFailure(StereoforgeError):
    """A matcher crashed, timed out or returned something that is not a disparity map."""


def one_line(text: str, limit: int = 300) -> str:
    """``text`` on one line (whitespace runs become one space), at most ``limit`` characters."""
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[:limit - 3] + "..."


def describe(value: Any) -> str:
    """What ``value`` is, for a message: an array's shape and dtype, else its type."""
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    return f"a {type(value).__name__}"
