"""``--format crestereo``: CREStereo's training layout, read by its code as it is.

::

    CREStereo/tree/000000_left.jpg        left image, JPEG (quality 95, no chroma subsampling)
    CREStereo/tree/000000_right.jpg       right image
    CREStereo/tree/000000_left.disp.png   left disparity: uint16 PNG of round(d * 32), 0 = none
    CREStereo/tree/000000_right.disp.png  right disparity (CREStereo reads it for flipped pairs)
    samples/000000/   calib.txt scene.json sample.json [preview.png]       stereoforge's own

Root per codebase: CREStereo's own ``CREStereoDataset(root=OUT/CREStereo)`` (it globs
``**/*_left.jpg``), unimatch's and IGEV++'s (one folder level: ``OUT/CREStereo``), torchvision's
``CREStereo(root=OUT)`` (it requires the four subsets ``shapenet``, ``reflective``, ``tree`` and
``hole`` to be non-empty, so samples go to them in turn: ``index % 4``; the names carry no meaning
here). Disparities in steps of 1/32 px up to 65535 / 32 = 2047.97 px
(:func:`matcher.io.encode_crestereo_disparity`); a rig that can reach past that is refused before
anything is rendered.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from matcher.io import (CRESTEREO_MAX, CRESTEREO_SCALE, StereoSample,
                        encode_crestereo_disparity, encode_jpeg, read_image,
                        read_crestereo_disparity)
from synth.formats.base import JPEG_QUALITY, Capacity, Layout, without_sky, write_tree
from synth.formats.middlebury import calib_txt

__all__ = ["CREStereoLayout", "LAYOUT", "SUBSETS"]

#: The subsets, in the order samples go to them (torchvision requires all four).
SUBSETS = ("tree", "shapenet", "reflective", "hole")
_ROOT = "CREStereo"
_SUFFIXES = ("_left.jpg", "_right.jpg", "_left.disp.png", "_right.disp.png")


class CREStereoLayout(Layout):
    """CREStereo's ``<subset>/<id>_left.jpg`` ... files."""

    name = "crestereo"
    title = "CREStereo"
    spec_form = "crestereo:DIR"
    capacity = Capacity(right_disparity=True, disp_quantum=1 / CRESTEREO_SCALE,
                        disp_max=CRESTEREO_MAX, lossless=False)
    tools_root = _ROOT
    sample_parent = "samples"
    placed = (_ROOT,)

    def key(self, index: int) -> str:
        return f"{_ROOT}/{SUBSETS[int(index) % len(SUBSETS)]}/{int(index):06d}"

    def write_files(self, pair: Any, dest: Path, *, scene: Any, index: int, clean: Any,
                    fsync: bool, image_deflate: str | None = None) -> list[Path]:
        stem = self.key(index)
        pair = without_sky(pair)  # CREStereo codes 0 as "no ground truth"
        data = (encode_jpeg(pair.left, quality=JPEG_QUALITY),
                encode_jpeg(pair.right, quality=JPEG_QUALITY),
                encode_crestereo_disparity(pair.disp_left),
                encode_crestereo_disparity(pair.disp_right))
        files = {f"{stem}{suffix}": d for suffix, d in zip(_SUFFIXES, data)}
        files["calib.txt"] = calib_txt(pair)
        return write_tree(dest, files, fsync=fsync)

    def read_key(self, root: Path, key: str) -> StereoSample:
        """``key``: a sample's path without ``_left.jpg`` (from ``root``)."""
        root = Path(root)
        left, right = (read_image(root / f"{key}{s}") for s in _SUFFIXES[:2])
        disp_left, disp_right = (read_crestereo_disparity(root / f"{key}{s}")
                                 for s in _SUFFIXES[2:])
        files = dict(zip(("left view", "right view", "left disparity", "right disparity"),
                         (root / f"{key}{s}" for s in _SUFFIXES)))
        return StereoSample(left, right, disp_left, disp_right, Path(key).name,
                            {"dataset": "crestereo", "layout": self.name, "path": key,
                             "files": files})

    def recognises(self, root: Path) -> bool:
        """``*_left.jpg`` with ``*_left.disp.png`` beside it, up to two levels below ``root``."""
        return any((p.parent / p.name.replace("_left.jpg", "_left.disp.png")).is_file()
                   for pattern in ("*_left.jpg", "*/*_left.jpg", "*/*/*_left.jpg")
                   for p in Path(root).glob(pattern))

    def discover(self, root: Path) -> list[str]:
        """Every ``*_left.jpg`` under ``root`` (any depth) with its three other files."""
        root = Path(root)
        keys = []
        for p in sorted(root.glob("**/*_left.jpg")):
            key = p.relative_to(root).as_posix().removesuffix("_left.jpg")
            if all((root / f"{key}{s}").is_file() for s in _SUFFIXES[1:]):
                keys.append(key)
        return keys


LAYOUT = CREStereoLayout()
