"""Training checkpoints (``MODEL.pt.ckpt``): the weights, the optimiser and the loop's state,
written atomically; read back only for the run that wrote them (same options, same data)."""

from __future__ import annotations

import io
from dataclasses import asdict, dataclass, field
from pathlib import Path

import torch

from matcher.io import atomic_write_bytes
from matcher.learned import DEFAULT_ARCHITECTURE
from stereoforge.errors import DatasetError
from synth.jobs.train.config import TrainConfig
from synth.jobs.train.sources import TrainSource

__all__ = ["State", "load_checkpoint", "save_checkpoint"]

_CKPT_FORMAT = "stereoforge-train-checkpoint"
#: What a checkpoint written before the registry of networks meant by keys it lacks.
_IDENTITY_BEFORE = {"arch": DEFAULT_ARCHITECTURE}


@dataclass
class State:
    """What a checkpoint holds besides the weights and the optimiser."""

    step: int = 0
    seconds: float = 0.0
    patches: int = 0
    rows: list = field(default_factory=list)
    row_loss: float = 0.0
    row_count: int = 0
    row_patches: int = 0
    row_seconds: float = 0.0


def save_checkpoint(path: Path, cfg: TrainConfig, sources: list[TrainSource],
                    net: torch.nn.Module, opt: torch.optim.Optimizer, state: State,
                    finished: bool) -> None:
    """Write the checkpoint of a run atomically (``finished``: the model file follows)."""
    buf = io.BytesIO()
    torch.save({"format": _CKPT_FORMAT, "version": 1, "config": cfg.identity(),
                "sources": [s.header() for s in sources], "state": asdict(state),
                "finished": finished,
                "net": {k: v.detach().to("cpu") for k, v in net.state_dict().items()},
                "opt": opt.state_dict()}, buf)
    atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(path: Path, cfg: TrainConfig, sources: list[TrainSource]) -> dict:
    """The checkpoint of the run ``cfg`` on ``sources`` (``--resume``).

    Raises
    ------
    DatasetError
        None there, not a checkpoint, made with other options or on other data.
    """
    import io

    from matcher.io.files import read_file

    if not path.exists():
        raise DatasetError(f"--resume: no checkpoint {path}; start without --resume")
    try:
        data = read_file(path, what="checkpoint")
    except (OSError, ValueError) as exc:
        raise DatasetError(f"--resume: {' '.join(str(exc).split())}; remove it and start again "
                           "without --resume") from None
    try:
        blob = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - any unreadable archive
        raise DatasetError(f"{path}: not a readable checkpoint ({type(exc).__name__}); remove "
                           "it and start again without --resume") from None
    if not isinstance(blob, dict) or blob.get("format") != _CKPT_FORMAT:
        raise DatasetError(f"{path}: not a stereoforge training checkpoint; remove it and start "
                           "again without --resume")
    want, got = cfg.identity(), {**_IDENTITY_BEFORE, **blob.get("config", {})}
    diff = [k for k in want if want[k] != got.get(k)]
    if diff:
        k = diff[0]
        raise DatasetError(f"--resume: the checkpoint {path} was made with {k} = {got.get(k)!r}, "
                           f"this run asks for {want[k]!r}; repeat the first run's options")
    hashes = [(s["spec"], s["hash"]) for s in blob.get("sources", [])]
    if hashes != [(s.spec, s.hash) for s in sources]:
        raise DatasetError(f"--resume: the training data changed since the checkpoint {path} "
                           "(another hash); start again without --resume")
    return blob
