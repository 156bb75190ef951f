"""``skimage:motorcycle`` (read only): Middlebury 2014 *Motorcycle* as scikit-image ships it.

:func:`skimage.data.stereo_motorcycle` gives the left and right views and the left ground truth
(NaN where there is none, read as ``inf``); no download, so every machine has one real pair.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from matcher.io import StereoSample
from synth.formats.base import Capacity, Layout, SceneRef, spec_error

__all__ = ["ScikitImageLayout", "LAYOUT"]

#: The stereo pairs scikit-image ships, by the name a SPEC gives.
PAIRS = ("motorcycle",)


class ScikitImageLayout(Layout):
    """scikit-image's stereo pair (:func:`skimage.data.stereo_motorcycle`)."""

    name = "skimage"
    title = "scikit-image data"
    capacity = Capacity(right_disparity=False)
    writable = False
    spec_form = "skimage:motorcycle"

    def discover(self, root: Path) -> list[str]:
        return list(PAIRS)

    def open_spec(self, spec: str, rest: str) -> list[SceneRef]:
        if rest not in PAIRS:
            raise spec_error(spec, f"scikit-image ships one stereo pair with ground truth: "
                                   f"skimage:{PAIRS[0]}")
        return [self.ref(Path(rest), rest, scene=f"skimage:{rest}", name=rest.title())]

    def read_key(self, root: Path, key: str) -> StereoSample:
        import skimage.data

        left, right, disp = skimage.data.stereo_motorcycle()
        gt = np.where(np.isfinite(disp), disp, np.inf).astype(np.float32)
        return StereoSample(left, right, gt, None, key, {"dataset": "skimage", "layout": self.name})


LAYOUT = ScikitImageLayout()
