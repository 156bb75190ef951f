"""Model files of the learned matcher: the weights and a header saying what they are.

A model file is a ``torch.save`` archive of a dict::

    {"format": "stereoforge-learned-matcher", "format_version": 1,
     "header": {...}, "state_dict": {...}}

read back with ``torch.load(..., weights_only=True)`` (no code runs on load). The header is plain
JSON data: ``architecture`` (its name in :mod:`matcher.learned.registry` and its options:
``mccnn-fast``'s channels, layers, kernel, patch), ``input`` (how a view is
turned into the network's input), ``cost_scale`` (the quantisation of the cost), ``inference``
(the default aggregation, left-right check and sub-pixel steps), ``training`` (the datasets'
names and hashes, steps, patches, seed, minutes, device, torch version) and the
``stereoforge_version`` that wrote it.

A file that is not such an archive (truncated, corrupt, another program's), or holds another
architecture, an architecture beyond its limits (:meth:`matcher.learned.registry.Arch.from_header`,
checked before the network is built: a header never sizes an allocation), inference steps out of
range, or weights that do not fit its header or are not finite, raises :class:`ModelError` with
one line naming the file and what is wrong.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch

from matcher.io import atomic_write_bytes
from matcher.learned.registry import Arch, architectures, get_architecture
from stereoforge.errors import FormatError, ParameterError, ParameterTypeError

__all__ = ["FORMAT", "FORMAT_VERSION", "INFERENCE_DEFAULTS", "MAX_AGGREGATE", "LearnedModel",
           "ModelError", "check_inference", "load_model", "model_bytes", "save_model"]

FORMAT = "stereoforge-learned-matcher"
FORMAT_VERSION = 1
#: The cost-volume steps a model runs with unless told otherwise (docs/learning.md).
INFERENCE_DEFAULTS = {"aggregate": 5, "lr_check": False, "subpixel": True}
#: Largest box side of the aggregation: a box sum of the largest cost fits uint32
#: (:data:`matcher.learned.cost.COST_SCALE`).
MAX_AGGREGATE = 511
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
    net : torch.nn.Module
        The network (:meth:`matcher.learned.registry.Arch.network`, its architecture as
        ``net.arch``), in eval mode after :func:`load_model`.
    header : dict
        See the module docstring.
    path : Path or None
        Where it was read from.
    """

    net: torch.nn.Module
    header: dict = field(default_factory=dict)
    path: Path | None = None

    @property
    def arch(self) -> Arch:
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


def check_inference(aggregate: object, lr_check: object, subpixel: object, *,
                    where: str = "") -> dict:
    """The inference steps, checked: ``aggregate`` 1 (none) or an odd box side
    3..:data:`MAX_AGGREGATE`, ``lr_check`` and ``subpixel`` booleans (:class:`ParameterError`)."""
    from stereoforge.validation import check_bool, check_int

    agg = check_int(aggregate, f"{where}aggregate", lo=1, hi=MAX_AGGREGATE)
    if agg != 1 and agg % 2 == 0:
        raise ParameterError(f"{where}aggregate: expected 1 (none) or an odd box side "
                             f"3..{MAX_AGGREGATE}, got {agg}")
    return {"aggregate": agg, "lr_check": check_bool(lr_check, f"{where}lr_check"),
            "subpixel": check_bool(subpixel, f"{where}subpixel")}


def _nonfinite(state: dict) -> str | None:
    """The name of the first weight tensor that is not floating point or holds NaN or inf."""
    for name, value in state.items():
        if not isinstance(value, torch.Tensor) or not value.is_floating_point() \
                or not bool(torch.isfinite(value).all()):
            return str(name)
    return None


def model_bytes(net: torch.nn.Module, header: dict) -> bytes:
    """The bytes of a model file for ``net`` (weights moved to the CPU) and ``header``.

    Raises
    ------
    ParameterError
        The header's inference steps are out of range, or a weight is NaN or inf (a diverged
        training): such a file would match garbage.
    """
    import io

    import json

    full = {"architecture": net.arch.to_dict(), "input": INPUT,
            "inference": dict(INFERENCE_DEFAULTS), "stereoforge_version": _version(), **header}
    full = json.loads(json.dumps(full, default=str))  # plain JSON data: weights_only reads it
    steps = {**INFERENCE_DEFAULTS, **full["inference"]}
    check_inference(steps["aggregate"], steps["lr_check"], steps["subpixel"],
                    where="header inference.")
    state = {k: v.detach().to("cpu").contiguous() for k, v in net.state_dict().items()}
    bad = _nonfinite(state)
    if bad is not None:
        raise ParameterError(f"model weights {bad} hold NaN or inf (the training diverged); "
                             "no model written: train again with a smaller learning rate")
    buf = io.BytesIO()
    torch.save({"format": FORMAT, "format_version": FORMAT_VERSION, "header": full,
                "state_dict": state}, buf)
    return buf.getvalue()


def save_model(path: str | os.PathLike[str], net: torch.nn.Module, header: dict) -> Path:
    """Write a model file atomically (temporary name, then rename); returns its path."""
    path = Path(path)
    atomic_write_bytes(path, model_bytes(net, header))
    return path


def _fail(path: Path, what: str) -> ModelError:
    return ModelError(f"{path}: {what}; {_TRAIN_HINT}")


def _architecture(path: Path, header: Any) -> Arch:
    if not isinstance(header, dict) or not isinstance(header.get("architecture"), dict):
        raise _fail(path, "the model header has no architecture")
    arch = header["architecture"]
    try:
        cls = get_architecture(arch.get("name"), where="the header's architecture")
    except ParameterError:
        raise _fail(path, f"architecture {arch.get('name')!r}, this version of stereoforge reads "
                          f"{', '.join(repr(n) for n in architectures())} models") from None
    if header.get("input", INPUT) != INPUT:
        raise _fail(path, f"a {cls.NAME} variant this version does not read (input "
                          f"{header.get('input')!r})")
    try:  # the one limit, before anything is allocated
        return cls.from_header(arch, where="the header's architecture")
    except ParameterError as exc:
        raise _fail(path, str(exc)) from None


def _inference(path: Path, header: dict) -> None:
    steps = header.get("inference", {})
    if not isinstance(steps, dict):
        raise _fail(path, f"the header's inference is {type(steps).__name__}, not a table")
    steps = {**INFERENCE_DEFAULTS, **steps}
    try:
        check_inference(steps["aggregate"], steps["lr_check"], steps["subpixel"],
                        where="the header's inference.")
    except (ParameterError, ParameterTypeError) as exc:
        raise _fail(path, str(exc)) from None


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
    from matcher.io.files import read_file

    path = Path(path)
    try:
        data = read_file(path, what="model file")  # a FIFO, a folder, ... named as such
    except FileNotFoundError:
        raise FileNotFoundError(f"model file {path} does not exist; {_TRAIN_HINT}") from None
    except FormatError as exc:
        raise _fail(path, str(exc).removeprefix(f"{path}: ")) from None
    try:
        import io

        blob = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
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
    _inference(path, header)
    state = blob.get("state_dict")
    if not isinstance(state, dict):
        raise _fail(path, "no weights in the file")
    bad = _nonfinite(state)
    if bad is not None:
        raise _fail(path, f"the weights {bad} are not finite numbers (NaN or inf): the model "
                          "would match garbage")
    net = arch.network()
    try:
        net.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()
        detail = " ".join(" ".join(first[1:3]).split())[:200] if len(first) > 1 else first[0][:200]
        raise _fail(path, f"weights do not fit the header's {arch.NAME} network of "
                          f"{arch.describe()} ({detail})") from None
    net.eval()
    return LearnedModel(net=net, header=dict(header), path=path)
