"""Progress bars that suit where they are written: a live bar on a terminal, a few plain lines in
a log file.

tqdm redraws its bar with carriage returns; in a log file or a CI log every redraw becomes a line.
:func:`progress` returns a tqdm bar when stderr is a terminal, and otherwise a :class:`LogProgress`
that prints a plain line at most once per 10 s or per 10 % of the total (whichever comes later),
plus the last one.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Iterable, Iterator
from typing import IO, Any

__all__ = ["LogProgress", "progress"]

#: A log line at most this often (seconds) ...
LOG_SECONDS = 10.0
#: ... and at most once per this fraction of the total.
LOG_FRACTION = 0.1


class LogProgress:
    """A progress report for a non-terminal: ``desc: 40/200 pairs (20 %), 12.3 s``, sparingly.

    Offers what stereoforge's jobs use of a tqdm bar: ``update``, ``close``, iteration, and use
    as a context manager.
    """

    def __init__(self, iterable: Iterable | None = None, *, total: int | None = None,
                 desc: str = "", unit: str = "it", initial: int = 0,
                 file: IO[str] | None = None, clock=time.monotonic) -> None:
        self.iterable = iterable
        if total is None and iterable is not None and hasattr(iterable, "__len__"):
            total = len(iterable)  # type: ignore[arg-type]
        self.total, self.desc, self.unit, self.n = total, desc, unit, initial
        self.file = file if file is not None else sys.stderr
        self._clock, self._start = clock, clock()
        self._last_t, self._last_n, self._closed = self._start, initial, False
        self._step = max(1, math.ceil(LOG_FRACTION * total)) if total else None
        self._postfix = ""

    def _line(self) -> str:
        done = f"{self.n}/{self.total}" if self.total else f"{self.n}"
        share = f" ({100.0 * self.n / self.total:.0f} %)" if self.total else ""
        tail = f", {self._postfix}" if self._postfix else ""
        return f"{self.desc}: {done} {self.unit}{share}, {self._clock() - self._start:.1f} s{tail}"

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        """Text appended to the next lines (tqdm's method of the same name)."""
        self._postfix = str(text)

    def update(self, n: int = 1) -> None:
        self.n += n
        now = self._clock()
        due_n = self._step is None or self.n - self._last_n >= self._step
        if due_n and now - self._last_t >= LOG_SECONDS:
            print(self._line(), file=self.file, flush=True)
            self._last_t, self._last_n = now, self.n

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            if self.n != self._last_n or self.n == 0:
                print(self._line(), file=self.file, flush=True)

    def __iter__(self) -> Iterator[Any]:
        try:
            for item in self.iterable or ():
                yield item
                self.update()
        finally:
            self.close()

    def __enter__(self) -> LogProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def progress(iterable: Iterable | None = None, *, total: int | None = None, desc: str = "",
             unit: str = "it", initial: int = 0, enabled: bool = True) -> Any:
    """A progress bar on stderr: tqdm on a terminal, :class:`LogProgress` elsewhere.

    ``enabled=False`` returns a tqdm bar that prints nothing (the same object either way to
    the caller: ``update``, ``close``, iteration).
    """
    from tqdm import tqdm

    if not enabled or sys.stderr.isatty():
        return tqdm(iterable, total=total, desc=desc, unit=unit, initial=initial,
                    disable=not enabled)
    return LogProgress(iterable, total=total, desc=desc, unit=unit, initial=initial)
