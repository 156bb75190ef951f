"""The output layouts :func:`synth.write_pair` writes (a leaf: the CLI reads it without importing
the writers)."""

__all__ = ["FORMATS", "DATASET_FORMATS", "MIDDLEBURY_LAYOUTS", "KITTI_ROOT"]

#: ``middlebury``: MiddEval3 scene folders; ``middlebury2014``: the 2014 scene archives' folders
#: (``disp0.pfm``); ``kitti``: KITTI 2015 (see docs/formats.md).
FORMATS = ("middlebury", "middlebury2014", "kitti")
#: What ``run_dataset`` writes: the layouts above, and ``webdataset`` tar shards of samples.
DATASET_FORMATS = (*FORMATS, "webdataset")
#: The formats of Middlebury scene folders, each to its ``layout`` of
#: :func:`matcher.io.write_middlebury`.
MIDDLEBURY_LAYOUTS = {"middlebury": "middeval3", "middlebury2014": "2014"}

#: Folder of a KITTI output that holds ``image_2/`` ... (KITTI's and RAFT-Stereo's ``training/``).
KITTI_ROOT = "training"
