"""Warm-up imported once by the fork server of :mod:`synth.dataset.engine.tasks` (never GL).

Importing this module loads the serial numba kernels of a dataset sample from numba's cache
(the occlusion mask, the noise lookup and passes) with tiny calls; the first load also runs numba's
one-off set-up (typing and target contexts, ~0.3 s). Every worker forked from the server then
starts with that done. It opens no GL context and starts no thread (the kernels are serial),
which keeps the fork safe. Besides the fork server, only the command line imports it, on a
cold numba cache, to compile every kernel of a sample once before any worker starts
(:func:`warm_sample_kernels`).
"""

from __future__ import annotations

import numpy as np

from synth.camera.rig import StereoRig
from synth.pair import ground_truth_from_depth, occlusion_mask
from synth.appearance.photometric import PhotometricParams, apply_photometric, gaussian_noise

__all__ = ["warm_sample_kernels"]


def warm_sample_kernels() -> None:
    """Compile (or load) every numba kernel a dataset sample runs, with tiny inputs of the
    samples' dtypes: the occlusion mask, the noise lookup and the edge density's Canny."""
    from synth.appearance.texture_control import edge_density

    _warm_ground_truth()
    _warm_noise()
    edge_density(np.zeros((16, 16, 3), np.uint8))


def _warm_ground_truth() -> None:
    """The occlusion mask alone and with the disparities of a pair's depths."""
    occlusion_mask(np.zeros((1, 2)), np.zeros((1, 2)))
    z = np.ones((1, 2), np.float32)
    ground_truth_from_depth(StereoRig.default(2, 1), z, z)


def _warm_noise() -> None:
    """The noise lookup and every fused noise pass (uint8 through a table, blurred float32,
    blurred through the gamma's table of 1/256 grey levels) with the gamma's power."""
    gaussian_noise((1,), 1.0, rng=0)
    img = np.zeros((1, 1, 3), np.uint8)
    for blur in (0.0, 0.5):
        for gamma in (1.0, 1.1):
            apply_photometric(img, img, PhotometricParams(noise_sigma=1.0, blur_sigma=blur,
                                                          gamma=gamma), rng=0)


_warm_ground_truth()
_warm_noise()
