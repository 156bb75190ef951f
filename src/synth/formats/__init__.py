"""The output layouts, one module each behind one interface (:class:`~synth.formats.base.Layout`).

============== ================================================== ===========================
name           what                                               module
============== ================================================== ===========================
middlebury     MiddEval3 scene folders (RAFT-Stereo, the SDK)     :mod:`.middlebury`
middlebury2014 the Middlebury 2014 archives' scene folders         :mod:`.middlebury2014`
kitti          KITTI 2015 training frames (RAFT-Stereo, devkit)   :mod:`.kitti`
webdataset     tar shards of MiddEval3 sample folders             :mod:`.webdataset`
sceneflow      FlyingThings3D's tree (RAFT, IGEV, unimatch, ...)  :mod:`.sceneflow`
crestereo      CREStereo's dataset layout                         :mod:`.crestereo`
fsd            FoundationStereo's FSD layout                      :mod:`.fsd`
============== ================================================== ===========================

A new layout is one module defining ``LAYOUT`` (a :class:`~synth.formats.base.Layout`) and one
line in ``_MODULES`` below. Nothing outside this package compares a format's name: the writers,
the dataset engine and storage, the readers (``StereoDataset``, ``eval-dataset``, ``validate
--real``, ``train``) and the command line ask :func:`get_layout`. Importing this package imports
no layout module (the command line reads :data:`FORMATS` without the writers).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from synth.formats.base import Layout

__all__ = ["FORMATS", "DATASET_FORMATS", "get_layout", "layouts"]

#: name -> module defining ``LAYOUT``; the order of ``--format``'s choices.
_MODULES = {
    "middlebury": "synth.formats.middlebury",
    "middlebury2014": "synth.formats.middlebury2014",
    "kitti": "synth.formats.kitti",
    "sceneflow": "synth.formats.sceneflow",
    "crestereo": "synth.formats.crestereo",
    "fsd": "synth.formats.fsd",
    "webdataset": "synth.formats.webdataset",
}
#: Layouts whose samples are packed in shards rather than folders (not for ``render``).
_SHARDED = ("webdataset",)

#: What ``run_dataset`` and ``stereoforge dataset --format`` write.
DATASET_FORMATS = tuple(_MODULES)
#: What ``write_pair`` and ``stereoforge render --format`` write: the layouts of sample folders.
FORMATS = tuple(n for n in _MODULES if n not in _SHARDED)


def get_layout(name: str) -> Layout:
    """The layout called ``name`` (one of :data:`DATASET_FORMATS`).

    Raises
    ------
    ValueError
        An unknown name (the message lists the known ones).

    Examples
    --------
    >>> get_layout("kitti").capacity.disp_max
    255.99609375
    """
    try:
        module = _MODULES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown format {name!r}; valid formats: "
                         f"{', '.join(DATASET_FORMATS)}") from None
    return importlib.import_module(module).LAYOUT


def layouts() -> list[Layout]:
    """Every registered layout, in :data:`DATASET_FORMATS` order."""
    return [get_layout(n) for n in DATASET_FORMATS]
