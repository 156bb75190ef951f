"""Warm-up imported once by the fork server of :mod:`synth.dataset.engine.tasks` (never GL).

Importing this module loads the serial numba kernels of a dataset sample from numba's cache
(the occlusion mask, the noise lookup) with tiny calls; the first load also runs numba's
one-off set-up (typing and target contexts, ~0.3 s). Every worker forked from the server then
starts with that done. It opens no GL context and starts no thread (the kernels are serial),
which keeps the fork safe. Besides the fork server, only the command line imports it, on a
cold numba cache, to compile every kernel of a sample once before any worker starts
(:func:`warm_sample_kernels`).
"""

from __future__ import annotations

import numpy as np

from synth.pair import occlusion_mask
from synth.appearance.photometric import gaussian_noise

__all__ = ["warm_sample_kernels"]


def warm_sample_kernels() -> None:
    """Compile (or load) every numba kernel a dataset sample runs, with tiny inputs of the
    samples' dtypes: the occlusion mask, the noise lookup and the edge density's Canny."""
    from synth.appearance.texture_control import edge_density

    occlusion_mask(np.zeros((1, 2)), np.zeros((1, 2)))
    gaussian_noise((1,), 1.0, rng=0)
    edge_density(np.zeros((16, 16, 3), np.uint8))


occlusion_mask(np.zeros((1, 2)), np.zeros((1, 2)))
gaussian_noise((1,), 1.0, rng=0)
