"""The layouts stereo data is stored in, one module each behind one interface
(:class:`~synth.formats.base.Layout`): those stereoforge writes, and read-only ones of real scenes.

============== ================================================== ===========================
name           what                                               module
============== ================================================== ===========================
middlebury     MiddEval3 scene folders (RAFT-Stereo, the SDK)     :mod:`.middlebury`
middlebury2014 the Middlebury 2014 archives' scene folders         :mod:`.middlebury2014`
kitti          KITTI 2015 training frames (RAFT-Stereo, devkit)   :mod:`.kitti`
sceneflow      FlyingThings3D's tree (RAFT, IGEV, unimatch, ...)  :mod:`.sceneflow`
crestereo      CREStereo's dataset layout                         :mod:`.crestereo`
fsd            FoundationStereo's FSD layout                      :mod:`.fsd`
webdataset     tar shards of MiddEval3 sample folders             :mod:`.webdataset`
middlebury2005 Middlebury 2005/2006 scene folders (read only)     :mod:`.middlebury2005`
eth3d          ETH3D two-view training scenes (read only)         :mod:`.eth3d`
drivingstereo  DrivingStereo frames (read only)                   :mod:`.drivingstereo`
skimage        scikit-image's *Motorcycle* (read only)            :mod:`.scikit_image`
============== ================================================== ===========================

A new layout is one module defining ``LAYOUT`` (a :class:`~synth.formats.base.Layout`) and one
line in ``_WRITTEN`` or ``_READ`` below (docs/extending.md). Nothing outside this package compares a format's
name: the writers, the dataset engine and storage, the readers (``StereoDataset``,
``eval-dataset``, ``validate --real``, ``train``, the benchmarks) and the command line ask
:func:`get_layout`, :func:`resolve_spec` and :meth:`~synth.formats.base.Layout.detect`. Importing
this package imports no layout module (the command line reads :data:`FORMATS` without the writers).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matcher.io import StereoSample
    from synth.formats.base import Layout, SceneRef

__all__ = ["DEFAULT_FORMAT", "FORMATS", "DATASET_FORMATS", "METRICS", "READ_ONLY", "FieldMetric",
           "get_layout",
           "layouts", "read_sample", "resolve_spec", "spec_forms"]

#: name -> module defining ``LAYOUT``: the layouts stereoforge writes, in the order of
#: ``--format``'s choices ...
_WRITTEN = {
    "middlebury": "synth.formats.middlebury",
    "middlebury2014": "synth.formats.middlebury2014",
    "kitti": "synth.formats.kitti",
    "sceneflow": "synth.formats.sceneflow",
    "crestereo": "synth.formats.crestereo",
    "fsd": "synth.formats.fsd",
    "webdataset": "synth.formats.webdataset",
}
#: ... and those it only reads (real scenes).
_READ = {
    "middlebury2005": "synth.formats.middlebury2005",
    "eth3d": "synth.formats.eth3d",
    "drivingstereo": "synth.formats.drivingstereo",
    "skimage": "synth.formats.scikit_image",
}
_MODULES = {**_WRITTEN, **_READ}
#: Layouts stereoforge reads but does not write.
READ_ONLY = tuple(_READ)
#: Layouts whose samples are packed in shards rather than folders (not for ``render``).
_SHARDED = ("webdataset",)

#: What ``run_dataset`` and ``stereoforge dataset --format`` write.
DATASET_FORMATS = tuple(_WRITTEN)
#: What ``write_pair`` and ``stereoforge render --format`` write: the layouts of sample folders.
FORMATS = tuple(n for n in DATASET_FORMATS if n not in _SHARDED)
#: The layout a command writes and a pair folder is read as when none is named.
DEFAULT_FORMAT = "middlebury"


@dataclass(frozen=True)
class FieldMetric:
    """A metric the field reports on a kind of real scene: a field of
    :class:`matcher.metrics.Metrics` (a percentage) over a region."""

    name: str
    field: str
    region: str
    text: str


#: The metric the field reports on each kind of real scene (:attr:`Layout.metric`): the column
#: ``bench transfer --real`` gives per real set.
METRICS = {m.name: m for m in (
    FieldMetric("bad2", "bad_2", "all",
                "bad-2: % of the pixels with ground truth whose error is > 2 px (Middlebury)"),
    FieldMetric("bad1_nonocc", "bad_1", "nonocc",
                "bad-1 on the non-occluded pixels: % with error > 1 px (ETH3D)"),
    FieldMetric("d1", "d1", "all",
                "D1: % of the pixels with ground truth whose error is > 3 px and > 5 % (KITTI, "
                "DrivingStereo)"),
)}


def get_layout(name: str) -> Layout:
    """The layout called ``name`` (one of :data:`DATASET_FORMATS` or :data:`READ_ONLY`).

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
                         f"{', '.join(_MODULES)}") from None
    return importlib.import_module(module).LAYOUT


def layouts() -> list[Layout]:
    """Every registered layout, written ones first (registry order)."""
    return [get_layout(n) for n in _MODULES]


def spec_forms() -> dict[str, str]:
    """The SPEC form of each layout that has one (:attr:`~synth.formats.base.Layout.spec_form`),
    by scheme, in registry order: what ``validate --real`` and ``train`` take.

    Examples
    --------
    >>> spec_forms()["eth3d"]
    'eth3d:DIR'
    """
    return {layout.scheme: layout.spec_form for layout in layouts()
            if layout.spec_form is not None}


def resolve_spec(spec: str) -> list[SceneRef]:
    """The samples a SPEC names (``eth3d:DIR``, ``middlebury:DIR:3``, ... :func:`spec_forms`),
    through the layout of its scheme (:meth:`~synth.formats.base.Layout.open_spec`).

    Raises
    ------
    ParameterError
        Not one of the forms, or what it names holds no sample: ``'SPEC': why``.

    Examples
    --------
    >>> [r.scene for r in resolve_spec("skimage:motorcycle")]
    ['skimage:motorcycle']
    """
    from synth.formats.base import spec_error

    forms = spec_forms()
    scheme, _, rest = str(spec).partition(":")
    if scheme not in forms or not rest:
        listed = list(forms.values())
        raise spec_error(str(spec), f"expected {', '.join(listed[:-1])} or {listed[-1]}")
    return get_layout(scheme).open_spec(str(spec), rest)


def read_sample(root: str | Path, key: str = ".", *, format: str = DEFAULT_FORMAT
                ) -> StereoSample:
    """Sample ``key`` of a tree of ``format`` in ``root`` (``"."``: ``root`` is the sample's
    folder), as the layout reads it (:meth:`~synth.formats.base.Layout.read_key`), confined to
    ``root`` and its arrays checked (:func:`~synth.formats.reading.checked_sample`)."""
    from matcher.io.files import confined
    from synth.formats.reading import checked_sample, damage_as_format_error

    with confined(root), damage_as_format_error(f"{root}/{key}"):
        return checked_sample(get_layout(format).read_key(Path(root), key), f"{root}/{key}")
