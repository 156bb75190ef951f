"""Honest wall-clock times of a call that may compile numba kernels first.

The first call of a matcher in a process pays for loading (or, on a fresh install, compiling)
its numba kernels and for starting numba's thread pool: CT 21x21 at 640x480 took 397 ms on its
first call and 40-48 ms warm on this project's 2-core machine. :func:`first_and_warm` runs a call
once, records how long numba spent compiling during it, and runs it again for the warm time.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["Timed", "first_and_warm"]


@dataclass(frozen=True)
class Timed:
    """Result of :func:`first_and_warm`.

    Attributes
    ----------
    result : object
        What the (warm) call returned.
    first_s, warm_s : float
        Wall-clock seconds of the first call and of the second.
    compile_s : float
        Seconds numba spent compiling during the first call (0 when its kernels came from the
        on-disk cache).
    """

    result: Any
    first_s: float
    warm_s: float
    compile_s: float

    def describe(self) -> str:
        """``"15.6 ms warm (first call 355 ms, kernels loaded from numba's cache)"``-like text."""
        how = (f"{self.compile_s * 1e3:.0f} ms of it compiling kernels once, cached for later runs"
               if self.compile_s > 0 else "kernels loaded from numba's cache")
        return f"{self.warm_s * 1e3:.1f} ms warm (first call {self.first_s * 1e3:.0f} ms, {how})"


def first_and_warm(call: Callable[[], Any]) -> Timed:
    """Run ``call`` twice: the first time recording numba's compile time, the second for speed.

    Examples
    --------
    >>> t = first_and_warm(lambda: sum(range(10)))
    >>> t.result, t.compile_s
    (45, 0.0)
    """
    from numba.core import event

    compiled = [0.0]

    def add(seconds: float) -> None:
        compiled[0] += seconds

    with event.install_timer("numba:compile", add):
        t0 = time.perf_counter()
        call()
        first = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = call()
    warm = time.perf_counter() - t0
    return Timed(result, first, warm, compiled[0])
