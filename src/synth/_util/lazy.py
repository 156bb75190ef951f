"""Package namespaces that load each public name from its module on first use (PEP 562).

``synth`` and ``synth.dataset`` re-export names whose modules import trimesh and numba. Loading
them lazily keeps ``stereoforge --help`` instant and lets the dataset command start its worker
server before it pays for those imports itself. The names stay explicit: each package lists them
in a table, sets ``__all__`` from it, and imports them under ``TYPE_CHECKING`` for tools.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_namespace"]


def lazy_namespace(package: str, exports: Mapping[str, str],
                   namespace: dict[str, Any]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for ``package``, whose public names are ``exports``.

    Parameters
    ----------
    package : str
        The package's name (for error messages).
    exports : mapping of str to str
        Public name -> the module that defines it.
    namespace : dict
        The package's ``globals()``: a loaded name is stored there, so it is looked up once.
    """

    def __getattr__(name: str) -> Any:
        try:
            module = exports[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
