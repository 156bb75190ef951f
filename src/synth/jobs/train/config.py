"""What a training run is (:class:`TrainConfig`: what a resumed run must repeat) and what it
made (:class:`TrainResult`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path

from matcher.learned import DEFAULT_ARCHITECTURE, Arch, get_architecture
from stereoforge.errors import StereoforgeError
from synth.jobs.train.patches import CROP, CROPS

__all__ = ["TrainConfig", "TrainInterrupted", "TrainResult"]


class TrainInterrupted(StereoforgeError):
    """Ctrl-C or SIGTERM: the checkpoint is written; ``--resume`` continues."""


@dataclass(frozen=True)
class TrainConfig:
    """Everything a run is defined by (what a resumed run must repeat).

    ``minutes`` and ``steps``: exactly one is set. ``lr`` drops tenfold for the last fifth of
    the budget.
    """

    sources: tuple[str, ...]
    out: str
    minutes: float | None = None
    steps: int | None = None
    seed: int = 0
    arch: str = DEFAULT_ARCHITECTURE
    arch_options: Mapping[str, int] = field(default_factory=dict)
    crops: int = CROPS
    crop: int = CROP
    lr: float = 1e-3
    val_fraction: float = 0.1

    def architecture(self) -> Arch:
        """The network's architecture: :attr:`arch` with :attr:`arch_options` (the others at
        their defaults), checked (:meth:`matcher.learned.registry.Arch.from_options`)."""
        return get_architecture(self.arch).from_options(dict(self.arch_options), where="train")

    def identity(self) -> dict:
        """What a checkpoint must match to be resumed (the output path aside): the options and
        every option of the architecture."""
        d = asdict(self)
        d.pop("out")
        d.pop("arch_options")
        d["sources"] = list(d["sources"])
        d.update({k: v for k, v in asdict(self.architecture()).items()})
        return d


@dataclass(frozen=True)
class TrainResult:
    """What a run made."""

    model: Path
    csv: Path
    checkpoint: Path
    steps: int
    patches: int
    seconds: float
    train_loss: float
    val_loss: float | None
    aggregate: int
    rows: list = field(default_factory=list)
