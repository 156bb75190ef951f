"""``--format middlebury``: MiddEval3 scene folders, where RAFT-Stereo and the MiddEval3 SDK look.

::

    MiddEval3/official_train.txt        the complete samples' names (RAFT-Stereo's scene list)
    MiddEval3/trainingF/000000/         im0.png im1.png [im1E.png im1L.png] disp0GT.pfm
                                        disp1GT.pfm mask0nocc.png calib.txt [flow0.flo]
                                        scene.json sample.json [preview.png]

``trainingF/`` is what RAFT-Stereo's ``Middlebury(root, split="F")`` and MiddEval3's ``runeval F``
walk; the sample folder is the scene folder, so stereoforge's ``scene.json`` and ``sample.json``
sit beside the files (the tools ignore them). See docs/formats.md.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from matcher.io import (StereoSample, atomic_write_bytes, encode_flo, format_calib,
                        load_middlebury_2014, read_flo, read_image, write_middlebury)
from synth.formats.base import Capacity, Layout, SceneRef, spec_error
from synth.formats.reading import calib_from_middlebury

__all__ = ["MiddleburyLayout", "LAYOUT", "SCENE_LAYOUTS", "calib_for", "calib_txt"]

#: RAFT-Stereo's list of the Middlebury scenes to load, inside the MiddEval3 root.
SCENE_LIST = "official_train.txt"


def calib_for(pair: Any) -> dict:
    """Middlebury ``calib.txt`` fields for a rendered pair (ndisp, vmin, vmax from its GT).

    ``vmin``/``vmax`` bound the finite left and right disparities (floor/ceil); ``ndisp`` is
    ``vmax + 1`` rounded up to a multiple of 16, as Middlebury's conservative search bound.
    """
    from synth._util.ranges import finite_range  # numba: imported when a pair is written

    lo, hi = finite_range(pair.disp_left, pair.disp_right)
    if lo > hi:  # no finite disparity at all
        lo = hi = 0.0
    vmin = int(math.floor(lo))
    vmax = int(math.ceil(hi))
    ndisp = int(16 * math.ceil((vmax + 1) / 16))
    return pair.rig.middlebury_calib(ndisp=ndisp, vmin=vmin, vmax=vmax)


def calib_txt(pair: Any) -> bytes:
    """The bytes of ``calib.txt`` of a rendered pair (:func:`calib_for`): the calibration
    sidecar of the layouts that have no place of their own for it."""
    return format_calib(calib_for(pair)).encode("ascii")


#: The layouts of one Middlebury scene folder, in the order they are tried.
SCENE_LAYOUTS = ("middlebury2014", "middlebury2005")
#: Left ground-truth files of a Middlebury scene folder (2014 names, then 2005/2006).
_TRUTH = ("disp0GT.pfm", "disp0.pfm", "disp1.png")


def _has_truth(folder: Path) -> bool:
    return any((folder / n).is_file() for n in _TRUTH)


def _scene_folders(root: Path) -> list[Path]:
    """``root`` when it is a scene folder (``im0.png``), else the scene folders one or two
    levels below it (``root/<scene>``, ``root/MiddEval3/trainingF/<scene>``-like)."""
    if (root / "im0.png").is_file():
        return [root]
    found = sorted(p.parent for p in root.glob("*/im0.png"))
    return found or sorted(p.parent for p in root.glob("*/*/im0.png"))


class MiddleburyLayout(Layout):
    """MiddEval3 scene folders (``layout="middeval3"`` of :func:`matcher.io.write_middlebury`)."""

    name = "middlebury"
    title = "MiddEval3"
    spec_form = "middlebury:DIR[:DIVISOR]"
    capacity = Capacity(right_disparity=True, flow=True, extra_ground_truth=True)
    tools_root = "MiddEval3"
    sample_parent = "MiddEval3/trainingF"
    io_layout = "middeval3"

    def write_files(self, pair: Any, dest: Path, *, scene: Any, index: int, clean: Any,
                    fsync: bool, image_deflate: str | None = None) -> list[Path]:
        written = list(write_middlebury(
            dest, left=pair.left, right=pair.right, disp_left=pair.disp_left,
            disp_right=pair.disp_right, mask_left=pair.mask_left, calib=calib_for(pair),
            fsync=fsync, right_exposure=pair.right_exposure, right_lighting=pair.right_lighting,
            highlight_left=pair.highlight_left, highlight_right=pair.highlight_right,
            sky_left=getattr(pair, "sky_left", None), layout=self.io_layout, image_deflate=image_deflate))
        if pair.flow_left is not None:  # the real cameras' exact correspondence
            written.append(atomic_write_bytes(dest / "flow0.flo", encode_flo(pair.flow_left),
                                              fsync=fsync))
        return written

    def finish_files(self, names: list[str]) -> dict[str, bytes]:
        """``MiddEval3/official_train.txt``: the scene names RAFT-Stereo's loader keeps."""
        return {f"{self.tools_root}/{SCENE_LIST}": "".join(f"{n}\n" for n in sorted(names)).encode()}

    def key(self, index: int) -> str:
        return f"{self.sample_parent}/{int(index):06d}"

    def read_key(self, root: Path, key: str) -> StereoSample:
        """The scene folder ``root/key``: :func:`matcher.io.load_middlebury_2014`, the exact
        flow (``flow0.flo``) and validate's region masks (``mask_<region>.png``) when there."""
        from matcher.regions import REGIONS

        folder = Path(root) / key
        s = load_middlebury_2014(folder)
        flow = read_flo(folder / "flow0.flo") if (folder / "flow0.flo").is_file() else None
        regions = ({n: read_image(folder / f"mask_{n}.png") > 0 for n in REGIONS}
                   if (folder / "mask_all.png").is_file() else None)
        return StereoSample(s.left, s.right, s.disp_left, s.disp_right, s.name,
                            {**s.meta, "layout": self.name}, s.mask_left,
                            calib_from_middlebury(s.meta.get("calib")), flow, regions)

    def discover(self, root: Path) -> list[str]:
        root = Path(root)
        return [p.relative_to(root).as_posix() or "." for p in _scene_folders(root)]

    def recognises(self, root: Path) -> bool:
        """A Middlebury scene folder with ground truth (2014/MiddEval3 or 2005/2006), or a
        folder holding such scene folders."""
        return any(Layout.detect(f, among=SCENE_LAYOUTS) is not None and _has_truth(f)
                   for f in (root, *sorted(p for p in root.iterdir() if p.is_dir())))

    def open_spec(self, spec: str, rest: str) -> list[SceneRef]:
        """``middlebury:DIR[:DIVISOR]``: a scene folder, or a folder of them, of the 2014 /
        MiddEval3 layout (``im0.png``) or the 2005/2006 one (``view1.png``; DIVISOR codes per
        pixel, inferred from the folder names when not given:
        :mod:`synth.formats.middlebury2005`)."""
        from synth.formats import get_layout

        path, divisor, tail = rest, None, ""
        head, _, tail = rest.rpartition(":")
        if head and not Path(rest).is_dir():  # DIR:DIVISOR
            path = head
            try:
                divisor = float(tail)
            except ValueError:
                divisor = math.nan
            if not (math.isfinite(divisor) and divisor > 0):
                raise spec_error(spec, f"DIVISOR must be a number > 0 (disparity = code / "
                                       f"DIVISOR: 3 at third size), got {tail!r}")
        root = Path(path)
        if not root.is_dir():
            raise spec_error(spec, f"{root} is not a folder; give a Middlebury scene folder or "
                                   "a folder of them")
        found = [(root, Layout.detect(root, among=SCENE_LAYOUTS))]
        if found[0][1] is None:
            found = [(p, Layout.detect(p, among=SCENE_LAYOUTS)) for p in sorted(root.iterdir())
                     if p.is_dir()]
            found = [(p, layout) for p, layout in found if layout is not None]
        if not found:
            raise spec_error(spec, f"no Middlebury scene in {root} (a scene folder holds "
                                   "view1.png, view5.png, disp1.png (2005/2006) or im0.png, "
                                   "im1.png, disp0GT.pfm (2014/MiddEval3))")
        out = []
        for folder, layout in found:
            scene = f"middlebury:{folder.parent.name}/{folder.name}"
            if layout is get_layout("middlebury2005"):
                out.append(layout.scene_ref(spec, folder, scene=scene, divisor=divisor))
                continue
            if divisor is not None:
                raise spec_error(spec, f"{folder} is in the 2014/MiddEval3 layout (im0.png), "
                                       "whose ground truth is in pixels: it takes no DIVISOR; "
                                       f"drop ':{tail}'")
            if not _has_truth(folder):
                raise spec_error(spec, f"{folder} has no ground truth: no disp0GT.pfm or "
                                       "disp0.pfm (MiddEval3 or 2014 archive name); add it or "
                                       "give another scene")
            out.append(layout.ref(folder, ".", scene=scene))
        return out


LAYOUT = MiddleburyLayout()
