"""The files of the optional ground truth beyond disparity (:mod:`synth.write.extra_ground_truth`
makes the arrays): their names in a Middlebury scene folder, their encoding, writing and reading.

=================  ===================  ================================================
kind               file                 encoding
=================  ===================  ================================================
``depth``          ``depth0.pfm``       float32 metres, ``inf`` where no surface
``normals``        ``normals0.pfm``     3-channel float32 unit normal (left camera axes)
``instance``       ``instance0.png``    16-bit grey: 1 + the object's index, 0 background
``semantic``       ``semantic0.png``    8-bit grey: the object's kind
``occlusion_right``  ``mask1nocc.png``  the right view's mask, coded as ``mask0nocc.png``
=================  ===================  ================================================
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from matcher.io import atomic_write_bytes, encode_png, encode_pfm

__all__ = ["GROUND_TRUTH", "EXTRA_FILES", "ground_truth_bytes", "read_ground_truth",
           "write_ground_truth"]

#: The optional ground-truth kinds, in the order they are written.
GROUND_TRUTH = ("depth", "normals", "instance", "semantic", "occlusion_right")
#: File of each kind in a Middlebury scene folder.
EXTRA_FILES = {"depth": "depth0.pfm", "normals": "normals0.pfm", "instance": "instance0.png",
            "semantic": "semantic0.png", "occlusion_right": "mask1nocc.png"}


def ground_truth_bytes(arrays: Mapping[str, np.ndarray]) -> dict[str, bytes]:
    """File name -> bytes of each array (:func:`synth.write.extra_ground_truth.render_ground_truth`)."""
    return {EXTRA_FILES[k]: (encode_pfm(a) if EXTRA_FILES[k].endswith(".pfm") else encode_png(a))
            for k, a in arrays.items()}


def write_ground_truth(folder: str | Path, arrays: Mapping[str, np.ndarray], *,
                       fsync: bool = True) -> list[Path]:
    """Write the arrays into a Middlebury scene folder (atomically, one file each)."""
    written = []
    for name, data in ground_truth_bytes(arrays).items():
        path = Path(folder) / name
        atomic_write_bytes(path, data, fsync=fsync)
        written.append(path)
    return written


def read_ground_truth(folder: str | Path) -> dict[str, np.ndarray]:
    """The optional ground truth written in a scene folder, by kind (the kinds absent there are
    left out): ``depth``, ``normals`` float32, ``instance`` uint16, ``semantic`` uint8,
    ``occlusion_right`` the right view's mask (uint8, coded as ``mask0nocc.png``).

    Raises
    ------
    DatasetError
        A PNG of them that is not grey (the folder was modified).
    """
    from matcher.io import read_pfm
    from stereoforge.errors import DatasetError

    def png(path: Path) -> np.ndarray:
        import cv2

        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if image is None or image.ndim != 2:
            raise DatasetError(f"{path}: not a grey PNG; the dataset directory was modified")
        return image

    dtypes = {"instance": np.uint16, "semantic": np.uint8, "occlusion_right": np.uint8}
    out: dict[str, np.ndarray] = {}
    for kind in GROUND_TRUTH:
        path = Path(folder) / EXTRA_FILES[kind]
        if path.is_file():
            out[kind] = (read_pfm(path).astype(np.float32, copy=False) if path.suffix == ".pfm"
                         else png(path).astype(dtypes[kind], copy=False))
    return out
