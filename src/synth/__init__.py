"""Labelled stereo pairs with exact ground truth: rig, renderer, pairs, photometry, datasets.

The public API, in one place::

    from synth import StereoRig, render_pair, run_dataset

- :class:`StereoRig` — a rectified pinhole pair (OpenCV convention, ``d = fx * B / Z``);
  :class:`RigErrors` (:class:`Distortion`, :class:`Defocus`) — how its real cameras deviate.
- :class:`Renderer`, :func:`render_pair`, :class:`StereoPair` — a pair of views with left/right
  disparity exact to float precision, depth and occlusion masks (headless GL: EGL or OSMesa).
- :class:`PhotometricParams`, :func:`apply_photometric` — seeded sensor models for the views.
- :func:`write_pair` — a pair in a Middlebury layout (MiddEval3, 2014 scenes) or KITTI 2015.
- :func:`run_dataset`, :func:`load_config`, :func:`read_manifest`, :func:`render_from_manifest` —
  deterministic, resumable datasets.
- :class:`StereoDataset` — a dataset directory as a map-style training dataset (numpy arrays).

Importing ``synth`` imports nothing else: each name is loaded from its module on first use
(PEP 562), so ``stereoforge --help`` and the dataset command's worker server start without
paying for trimesh and numba first. No GL context is started and no OpenGL imported either way.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from synth._util.lazy import lazy_namespace

if TYPE_CHECKING:
    from synth.dataset import (
        ConfigError,
        DatasetConfig,
        DatasetError,
        DatasetRun,
        SampleError,
        StereoDataset,
        load_config,
        read_manifest,
        render_from_manifest,
        run_dataset,
    )
    from synth.camera.lens import Defocus, Distortion, RigErrors
    from synth.write.export import OutputDirError, write_pair
    from synth.formats import FORMATS
    from synth.pair import StereoPair, occlusion_mask, render_pair
    from synth.appearance.photometric import PhotometricPair, PhotometricParams, apply_photometric
    from synth.render import BACKENDS, GLBackendError, Renderer, ViewRender, resolve_backend
    from synth.camera.rig import StereoRig

#: Public name -> the module that defines it.
_EXPORTS = {
    "BACKENDS": "synth.render",
    "ConfigError": "synth.dataset",
    "DatasetConfig": "synth.dataset",
    "DatasetError": "synth.dataset",
    "DatasetRun": "synth.dataset",
    "Defocus": "synth.camera.lens",
    "Distortion": "synth.camera.lens",
    "FORMATS": "synth.formats",
    "GLBackendError": "synth.render",
    "OutputDirError": "synth.write.export",
    "PhotometricPair": "synth.appearance.photometric",
    "PhotometricParams": "synth.appearance.photometric",
    "Renderer": "synth.render",
    "RigErrors": "synth.camera.lens",
    "SampleError": "synth.dataset",
    "StereoDataset": "synth.dataset",
    "StereoPair": "synth.pair",
    "StereoRig": "synth.camera.rig",
    "ViewRender": "synth.render",
    "apply_photometric": "synth.appearance.photometric",
    "load_config": "synth.dataset",
    "occlusion_mask": "synth.pair",
    "read_manifest": "synth.dataset",
    "render_from_manifest": "synth.dataset",
    "render_pair": "synth.pair",
    "resolve_backend": "synth.render",
    "run_dataset": "synth.dataset",
    "write_pair": "synth.write.export",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_namespace(__name__, _EXPORTS, globals())
