"""Model files of the learned matcher: the weights and a header saying what they are.

A model file is a ``torch.save`` archive of a dict::

    {"format": "stereoforge-learned-matcher", "format_version": 1,
     "header": {...}, "state_dict": {...}}

read back with ``torch.load(..., weights_only=True)`` (no code runs on load). The header is plain
JSON data: ``architecture`` (name, channels, layers, kernel, patch), ``input`` (how a view is
turned into the network's input), ``cost_scale`` (the quantisation of the cost), ``inference``
(the default aggregation, left-right check and sub-pixel steps), ``training`` (the datasets'
names and hashes, steps, patches, seed, minutes, device, torch version) and the
``stereoforge_version`` that wrote it.

A file that is not such an archive (truncated, corrupt, another program's), or holds another
architecture, or weights that do not fit its header, raises :class:`ModelError` with one line
naming the file and what is wrong.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch

from matcher.io import atomic_write_bytes
from matcher.learned.network import ARCHITECTURE, Architecture, PatchNet
from stereoforge.errors import FormatError

__all__ = ["FORMAT", "FORMAT_VERSION", "INFERENCE_DEFAULTS", "LearnedModel", "ModelError",
           "load_model", "model_bytes", "save_model"]

FORMAT = "stereoforge-learned-matcher"
FORMAT_VERSION = 1
#: The cost-volume steps a model runs with unless told otherwise (docs/learning.md).
INFERENCE_DEFAULTS = {"aggregate": 5, "lr_check": False, "subpixel": True}
#: Input transform recorded in the header; the only one this version reads.
INPUT = "grey BT.601, standardised per image (zero mean, unit std)"
_TRAIN_HINT = "train one with `stereoforge train DATASET --out MODEL.pt`"


class ModelError(FormatError):
    """A model file cannot be used: corrupt, another format or architecture, mismatched weights."""


@dataclass(frozen=True, eq=False)
class LearnedModel:
    """A network with its header.

    Attributes
    ----------
    net : PatchNet
        In eval mode after :func:`load_model`.
    header : dict
        See the module docstring.
    path : Path or None
        Where it was read from.
    """

    net: PatchNet
    header: dict = field(default_factory=dict)
    path: Path | None = None

    @property
    def arch(self) -> Architecture:
        return self.net.arch

    @property
    def inference(self) -> dict:
        """The header's inference defaults, completed with :data:`INFERENCE_DEFAULTS`."""
        return {**INFERENCE_DEFAULTS, **self.header.get("inference", {})}


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("stereoforge")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def model_bytes(net: PatchNet, header: dict) -> bytes:
    """The bytes of a model file for ``net`` (weights moved to the CPU) and ``header``."""
    import io

    import json

    full = {"architecture": net.arch.to_dict(), "input": INPUT,
            "inference": dict(INFERENCE_DEFAULTS), "stereoforge_version": _version(), **header}
    full = json.loads(json.dumps(full, default=str))  # plain JSON data: weights_only reads it
    state = {k: v.detach().to("cpu").contiguous() for k, v in net.state_dict().items()}
    buf = io.BytesIO()
    torch.save({"format": FORMAT, "format_version": FORMAT_VERSION, "header": full,
                "state_dict": state}, buf)
    return buf.getvalue()


def save_model(path: str | os.PathLike[str], net: PatchNet, header: dict) -> Path:
    """Write a model file atomically (temporary name, then rename); returns its path."""
    path = Path(path)
    atomic_write_bytes(path, model_bytes(net, header))
    return path


def _fail(path: Path, what: str) -> ModelError:
    return ModelError(f"{path}: {what}; {_TRAIN_HINT}")


def _architecture(path: Path, header: Any) -> Architecture:
    if not isinstance(header, dict) or not isinstance(header.get("architecture"), dict):
        raise _fail(path, "the model header has no architecture")
    arch = header["architecture"]
    if arch.get("name") != ARCHITECTURE:
        raise _fail(path, f"architecture {arch.get('name')!r}, this version of stereoforge reads "
                          f"{ARCHITECTURE!r} models")
    if arch.get("kernel", 3) != 3 or header.get("input", INPUT) != INPUT:
        raise _fail(path, f"a {ARCHITECTURE} variant this version does not read (kernel "
                          f"{arch.get('kernel')!r}, input {header.get('input')!r})")
    channels, layers = arch.get("channels"), arch.get("layers")
    if not all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 1024
               for v in (channels, layers)):
        raise _fail(path, f"architecture with channels {channels!r} and layers {layers!r} "
                          "(expected integers 1..1024)")
    return Architecture(channels=channels, layers=layers)


def load_model(path: str | os.PathLike[str]) -> LearnedModel:
    """Read a model file (on the CPU; move ``.net`` yourself for a GPU).

    Raises
    ------
    FileNotFoundError
        No such file.
    ModelError
        The file is not a stereoforge model, holds another architecture, or its weights do not
        fit its header.
    """
    path = Path(path)
    if path.is_dir():
        raise _fail(path, "is a directory, not a model file")
    if not path.is_file():
        raise FileNotFoundError(f"model file {path} does not exist; {_TRAIN_HINT}")
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - torch raises many kinds for a bad archive
        text = " ".join(str(exc).split())[:160]
        raise _fail(path, f"not a readable model file ({type(exc).__name__}: {text})") from None
    if not isinstance(blob, dict) or blob.get("format") != FORMAT:
        raise _fail(path, f"not a {FORMAT} file (a torch archive of something else)")
    if blob.get("format_version") != FORMAT_VERSION:
        raise _fail(path, f"format version {blob.get('format_version')!r}, this version of "
                          f"stereoforge reads {FORMAT_VERSION}")
    header = blob.get("header")
    arch = _architecture(path, header)
    net = PatchNet(arch)
    state = blob.get("state_dict")
    if not isinstance(state, dict):
        raise _fail(path, "no weights in the file")
    try:
        net.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()
        detail = " ".join(" ".join(first[1:3]).split())[:200] if len(first) > 1 else first[0][:200]
        raise _fail(path, f"weights do not fit the header's {ARCHITECTURE} with "
                          f"{arch.channels} channels and {arch.layers} layers ({detail})") from None
    net.eval()
    return LearnedModel(net=net, header=dict(header), path=path)
