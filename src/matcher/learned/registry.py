"""The learned networks, by name: what an architecture states, and how one is added.

An architecture is a frozen dataclass whose fields are its options (integers), registered under
its :attr:`Arch.NAME` here. It states

- its options (:attr:`Arch.OPTIONS`: name, default, range, what it is), checked with the one
  limit of every network, :data:`MAX_WEIGHTS`, before anything is allocated
  (:meth:`Arch.from_options`), for ``stereoforge train --arch NAME --arch-option K=V`` and for
  a model file's header alike (:meth:`Arch.from_header`);
- its **halo** (:attr:`Arch.halo`): the pixels of context on each side that a feature needs, so
  the trainer cuts crops with it and inference pads the views by it;
- its features (:attr:`Arch.features`: channels of the unit feature vector of a pixel), the
  window it reports (:attr:`Arch.patch`), and its header record (:meth:`Arch.to_dict`);
- the network (:meth:`Arch.network`): an ``nn.Module`` mapping ``(N, 1, H + 2 halo, W + 2 halo)``
  standardised grey views to ``(N, features, H, W)`` L2-normalised features, with the
  architecture as its ``arch`` attribute.

A new network is one module defining such a class and one line in ``_BUILT_IN`` (or a
:func:`register_architecture` call); docs/extending.md walks through one.
"""

from __future__ import annotations

import dataclasses
import importlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

__all__ = ["DEFAULT_ARCHITECTURE", "MAX_WEIGHTS", "Arch", "Option", "architectures",
           "get_architecture", "register_architecture"]

#: Weights and biases a network may have (float32: 128 MiB), whatever its architecture.
MAX_WEIGHTS = 1 << 25
#: The network ``stereoforge train`` builds unless told otherwise.
DEFAULT_ARCHITECTURE = "mccnn-fast"
#: name -> "module:class" of the built-in architectures (imported when first asked for).
_BUILT_IN = {
    "mccnn-fast": "matcher.learned.network:Architecture",
}
_REGISTERED: dict[str, type] = {}


@dataclass(frozen=True)
class Option:
    """One option of an architecture: an integer in ``lo .. hi``."""

    name: str
    default: int
    lo: int
    hi: int
    help: str


class Arch:
    """What every architecture class provides (subclass it as a frozen dataclass whose fields
    are the :attr:`OPTIONS`); see the module docstring."""

    NAME: ClassVar[str] = ""
    OPTIONS: ClassVar[tuple[Option, ...]] = ()

    @property
    def halo(self) -> int:
        """Pixels of context on each side of a feature."""
        raise NotImplementedError

    @property
    def features(self) -> int:
        """Channels of a pixel's feature vector."""
        raise NotImplementedError

    @property
    def patch(self) -> int:
        """Side of the window a feature describes (``2 * halo + 1``)."""
        return 2 * self.halo + 1

    @property
    def weights(self) -> int:
        """Weights and biases of the network."""
        raise NotImplementedError

    def describe(self) -> str:
        """A few words for messages: ``channels 8, layers 2 (5x5 patches)``."""
        values = ", ".join(f"{o.name} {getattr(self, o.name)}" for o in self.OPTIONS)
        return f"{values} ({self.patch}x{self.patch} patches)"

    def to_dict(self) -> dict:
        """The header record: ``name`` and every option."""
        return {"name": self.NAME, **{o.name: getattr(self, o.name) for o in self.OPTIONS}}

    def network(self) -> Any:
        """A new network of this architecture (an ``nn.Module`` with ``.arch``)."""
        raise NotImplementedError

    @classmethod
    def from_options(cls, options: Mapping[str, object], *, where: str = "architecture") -> Arch:
        """The architecture of ``options`` (the others at their defaults), each within its range
        and all within :data:`MAX_WEIGHTS`; nothing is allocated.

        Raises
        ------
        ParameterError
            An option the architecture does not have, a value that is not an integer in its
            range, or too many weights.
        """
        import numpy as np

        from stereoforge.errors import ParameterError

        known = {o.name: o for o in cls.OPTIONS}
        unknown = [k for k in options if k not in known]
        if unknown:
            raise ParameterError(f"{where}: the {cls.NAME} network has no option {unknown[0]!r}; "
                                 f"its options: {', '.join(known) or 'none'}")
        values = {}
        for o in cls.OPTIONS:
            value = options.get(o.name, o.default)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
                    or not o.lo <= value <= o.hi:
                raise ParameterError(f"{where}: {o.name}: expected an integer {o.lo}..{o.hi}, got "
                                     f"{value!r}")
            values[o.name] = int(value)
        arch = cls(**values)  # type: ignore[call-arg]
        if arch.weights > MAX_WEIGHTS:
            shape = " x ".join(f"{v} {k}" for k, v in values.items())
            raise ParameterError(f"{where}: {shape} has {arch.weights:,} weights; at most "
                                 f"{MAX_WEIGHTS:,} (use fewer {' or '.join(values)})")
        return arch

    @classmethod
    def from_header(cls, record: Mapping[str, Any], *, where: str) -> Arch:
        """The architecture of a model header's record (:meth:`to_dict`), checked as
        :meth:`from_options` checks; the keys beyond the options are the architecture's to
        check (default: ignored)."""
        return cls.from_options({o.name: record.get(o.name) for o in cls.OPTIONS}, where=where)


def register_architecture(cls: type) -> type:
    """Add an architecture class (replacing one of the same name) and return it; usable as a
    decorator."""
    if not (isinstance(cls, type) and issubclass(cls, Arch) and dataclasses.is_dataclass(cls)
            and cls.NAME):
        raise TypeError(f"an architecture is a dataclass subclass of Arch with a NAME, got {cls!r}")
    _REGISTERED[cls.NAME] = cls
    return cls


def architectures() -> tuple[str, ...]:
    """The names of every architecture, built-in first."""
    return tuple(dict.fromkeys([*_BUILT_IN, *_REGISTERED]))


def get_architecture(name: object, *, where: str = "--arch") -> type:
    """The architecture class called ``name``.

    Raises
    ------
    ParameterError
        No such architecture (the message lists them).

    Examples
    --------
    >>> get_architecture("mccnn-fast")().halo
    4
    """
    from stereoforge.errors import ParameterError

    if isinstance(name, str) and name in _REGISTERED:
        return _REGISTERED[name]
    if isinstance(name, str) and name in _BUILT_IN:
        module, _, attr = _BUILT_IN[name].partition(":")
        return register_architecture(getattr(importlib.import_module(module), attr))
    raise ParameterError(f"{where}: no network architecture {name!r}; architectures: "
                         f"{', '.join(architectures())}")
