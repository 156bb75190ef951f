"""``stereoforge train``: the reference learned matcher (:mod:`matcher.learned`) trained on
stereoforge datasets and real scenes (this package and :mod:`matcher.learned` are the only ones
that import PyTorch).

- :mod:`~synth.jobs.train.sources`: the datasets and real folders, as pairs with visible pixels;
- :mod:`~synth.jobs.train.patches`: the batches of each step, a pure function of (seed, step);
- :mod:`~synth.jobs.train.loop`: the loop, checkpoints, resume, the loss CSV, the model file.
"""

from synth.jobs.train.loop import (
    AGGREGATES,
    CSV_COLUMNS,
    GPU_CROPS,
    ROW_STEPS,
    TrainConfig,
    TrainInterrupted,
    TrainOutOfMemory,
    TrainResult,
    aggregate_bad3,
    default_crops,
    train,
)
from synth.jobs.train.patches import CROP, CROPS, PatchBatches
from synth.jobs.train.sources import TrainPair, TrainSource, open_source, open_sources

__all__ = [
    "AGGREGATES",
    "CROP",
    "CROPS",
    "CSV_COLUMNS",
    "GPU_CROPS",
    "PatchBatches",
    "ROW_STEPS",
    "TrainConfig",
    "TrainInterrupted",
    "TrainOutOfMemory",
    "TrainPair",
    "TrainResult",
    "TrainSource",
    "aggregate_bad3",
    "default_crops",
    "open_source",
    "open_sources",
    "train",
]
