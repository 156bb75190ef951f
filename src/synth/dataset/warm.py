"""Warm-up imported once by the fork server of :mod:`synth.dataset.engine` (never GL).

Importing this module loads the serial numba kernels of a dataset sample from numba's cache
(the occlusion mask, the noise lookup) with tiny calls; the first load also runs numba's
one-off set-up (typing and target contexts, ~0.3 s). Every worker forked from the server then
starts with that done. It opens no GL context and starts no thread (the kernels are serial),
which keeps the fork safe. Nothing else should import it.
"""

from __future__ import annotations

import numpy as np

from synth.pair import occlusion_mask
from synth.photometric import gaussian_noise

__all__: list[str] = []

occlusion_mask(np.zeros((1, 2)), np.zeros((1, 2)))
gaussian_noise((1,), 1.0, rng=0)
