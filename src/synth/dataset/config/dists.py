"""One parameter's distribution in a dataset configuration: fixed, uniform, log-uniform or a
choice (:class:`Dist`), and its draw from a sample's generator."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Dist"]


@dataclass(frozen=True)
class Dist:
    """A distribution of one parameter.

    Parameters
    ----------
    kind : {"fixed", "uniform", "loguniform", "choice"}
    args : tuple
        ``(value,)`` for fixed, ``(a, b)`` for uniform/loguniform, the values for choice.
    integer : bool
        Draws of uniform/loguniform are integers in ``[a, b]``.

    Examples
    --------
    >>> d = Dist("uniform", (1.0, 2.0))
    >>> 1.0 <= d.sample(np.random.default_rng(0)) <= 2.0
    True
    >>> Dist("choice", ("a", "b")).to_toml()
    {'choice': ['a', 'b']}
    """

    kind: str
    args: tuple[Any, ...]
    integer: bool = False

    def sample(self, rng: np.random.Generator) -> Any:
        """One draw (plain Python value). Fixed values consume no randomness."""
        if self.kind == "fixed":
            return self.args[0]
        if self.kind == "choice":
            value = self.args[int(rng.integers(len(self.args)))]
            return value
        a, b = self.args
        if self.kind == "uniform":
            if self.integer:
                return int(rng.integers(int(a), int(b) + 1))
            return float(rng.uniform(a, b))
        x = math.exp(rng.uniform(math.log(a), math.log(b + 1 if self.integer else b)))
        return min(int(math.floor(x)), int(b)) if self.integer else float(x)

    def to_toml(self) -> Any:
        """The TOML/JSON value this distribution was written as."""
        return self.args[0] if self.kind == "fixed" else {self.kind: list(self.args)}
