"""The output layouts :func:`synth.write_pair` writes (a leaf: the CLI reads it without importing
the writers)."""

__all__ = ["FORMATS", "DATASET_FORMATS", "KITTI_ROOT"]

#: ``middlebury``: Middlebury 2014 scene folders; ``kitti``: KITTI 2015 (see docs/formats.md).
FORMATS = ("middlebury", "kitti")
#: What ``run_dataset`` writes: the layouts above, and ``webdataset`` tar shards of samples.
DATASET_FORMATS = (*FORMATS, "webdataset")

#: Folder of a KITTI output that holds ``image_2/`` ... (KITTI's and RAFT-Stereo's ``training/``).
KITTI_ROOT = "training"
