"""Where the learned matcher runs: ``auto``, ``cpu``, ``cuda`` or ``cuda:N``, checked once.

``auto`` is CUDA where torch sees a GPU and the CPU elsewhere. A device torch cannot use here
(an unknown name, ``cuda`` without a GPU, ``cuda:N`` past the last GPU) is a
:class:`~stereoforge.errors.ParameterError` naming ``what`` and the fix.
"""

from __future__ import annotations

import re

import torch

from stereoforge.errors import ParameterError

__all__ = ["check_device", "resolve_device"]

_NAME = re.compile(r"^(auto|cpu|cuda(:[0-9]+)?)$")


def check_device(value: object, what: str = "device") -> str:
    """``value`` as a lower-case device name (``auto`` kept); ParameterError if torch cannot use it."""
    name = str(value).strip().lower() if isinstance(value, (str, torch.device)) else None
    if name is None or not _NAME.match(name):
        raise ParameterError(f"{what}: expected auto, cpu, cuda or cuda:N, got {value!r}")
    if name.startswith("cuda"):
        count = torch.cuda.device_count() if torch.cuda.is_available() else 0
        if count == 0:
            raise ParameterError(f"{what}: {name!r} but torch sees no CUDA GPU here; use cpu "
                                 "(or auto)")
        index = int(name.partition(":")[2] or 0)
        if index >= count:
            raise ParameterError(f"{what}: {name!r} but torch sees {count} GPU(s) (cuda:0 .. "
                                 f"cuda:{count - 1}); choose one of them, or auto")
    return name


def resolve_device(value: object, what: str = "device") -> str:
    """The concrete device of ``value`` (:func:`check_device`): ``auto`` becomes ``cuda`` where
    torch sees a GPU, else ``cpu``."""
    name = check_device(value, what)
    if name == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    return name
