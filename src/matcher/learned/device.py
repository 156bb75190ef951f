"""Where the learned matcher runs: ``auto``, ``cpu``, ``cuda`` or ``cuda:N``, checked once,
before any work.

``auto`` is CUDA where torch sees a GPU and the CPU elsewhere. A device torch cannot use here
(an unknown name, ``cuda`` without a GPU, ``cuda:N`` past the last GPU) is a
:class:`~stereoforge.errors.ParameterError` naming ``what`` and the fix. ``stereoforge train
--device``, ``stereoforge bench transfer --device`` and a ``learned:MODEL.pt?device=...`` MATCHER
string call it first, so a typo or a GPU that is not there is refused before datasets are
rendered, a training starts or a model is read.
"""

from __future__ import annotations

import re

from stereoforge.errors import ParameterError

__all__ = ["DEVICES", "check_device", "device_name"]

#: What a device value may be (the message of a refusal lists it).
DEVICES = "auto, cpu, cuda or cuda:N"


def check_device(value: object, what: str = "device") -> str:
    """``value`` as a device name torch takes (lower case, stripped; ``auto`` kept), or
    :class:`ParameterError`.

    Parameters
    ----------
    value : str
    what : str
        How the caller names the value in messages (``--device``).

    Raises
    ------
    ParameterError
        Anything else, ``cuda`` where torch sees no GPU, ``cuda:N`` beyond the GPUs it sees.

    Examples
    --------
    >>> check_device(" CPU ", "--device")
    'cpu'
    >>> check_device("gpu", "--device")
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: --device: expected auto, cpu, cuda or cuda:N, got 'gpu'
    """
    name = str(value).strip().lower() if isinstance(value, str) else None
    if name in ("auto", "cpu"):
        return name
    found = re.fullmatch(r"cuda(?::([0-9]+))?", name or "")
    if found is None:
        raise ParameterError(f"{what}: expected {DEVICES}, got {value!r}")
    import torch

    count = torch.cuda.device_count() if torch.cuda.is_available() else 0
    if count == 0:
        raise ParameterError(f"{what}: {name!r} but torch sees no CUDA GPU here; use cpu "
                             "(or auto)")
    if found.group(1) is not None and int(found.group(1)) >= count:
        raise ParameterError(f"{what}: {name!r} but torch sees {count} GPU(s) (cuda:0 .. "
                             f"cuda:{count - 1}); choose one of them, or auto")
    return name


def device_name(value: object, what: str = "device") -> str:
    """The name of the concrete device of ``value`` (:func:`check_device`): ``auto`` becomes ``cuda`` where
    torch sees a GPU, else ``cpu``."""
    name = check_device(value, what)
    if name == "auto":
        import torch

        return "cuda" if torch.cuda.is_available() else "cpu"
    return name
