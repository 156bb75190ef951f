"""Where the learned matcher runs: one check of a ``--device`` value, made before any work.

``stereoforge train --device`` and ``stereoforge bench transfer --device`` call
:func:`check_device` first, so a typo or a GPU that is not there is refused before datasets
are rendered or a training starts.
"""

from __future__ import annotations

import re

from stereoforge.errors import ParameterError

__all__ = ["DEVICES", "check_device"]

#: What a device value may be (the message of a refusal lists it).
DEVICES = "auto, cpu, cuda or cuda:N"


def check_device(value: object, what: str = "device") -> str:
    """``value`` as a device name torch takes (lower case, stripped), or :class:`ParameterError`.

    Accepted: ``auto`` (CUDA when torch sees a GPU, else the CPU), ``cpu``, ``cuda`` and
    ``cuda:N`` where torch sees a GPU (and at least ``N + 1`` of them).

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
        raise ParameterError(f"{what} {value!r}: torch sees no CUDA GPU here; use --device cpu "
                             "(or auto)")
    if found.group(1) is not None and int(found.group(1)) >= count:
        raise ParameterError(f"{what} {value!r}: torch sees {count} CUDA GPU(s) (cuda:0 .. "
                             f"cuda:{count - 1}); choose one of them")
    return name
