"""``stereoforge train``: the reference learned matcher (:mod:`matcher.learned`) trained on
stereoforge datasets and real scenes (this package and :mod:`matcher.learned` are the only ones
that import PyTorch).

- :mod:`~synth.jobs.train.sources`: the datasets and real folders, as pairs with visible pixels;
- :mod:`~synth.jobs.train.patches`: the batches of each step, a pure function of (seed, step);
- :mod:`~synth.jobs.train.config`: what a run is (:class:`TrainConfig`, the network by name) and
  made;
- :mod:`~synth.jobs.train.loop`: the run in three phases (prepare, step, finish), the loss CSV,
  the model file; :mod:`~synth.jobs.train.steps` the loss of a step,
  :mod:`~synth.jobs.train.checkpoint` checkpoints and resume, :mod:`~synth.jobs.train.aggregate`
  the default aggregation, :mod:`~synth.jobs.train.checks` what is refused.
"""

from synth.jobs.train.aggregate import AGGREGATES, aggregate_bad3
from synth.jobs.train.checks import TrainOutOfMemory
from synth.jobs.train.config import TrainConfig, TrainInterrupted, TrainResult
from synth.jobs.train.loop import CSV_COLUMNS, GPU_CROPS, ROW_STEPS, default_crops, train
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
