"""Real scenes beside the synthetic axes: ``stereoforge validate --real SPEC``.

A SPEC names real stereo pairs with ground truth, read by :mod:`matcher.io`'s readers:

- ``middlebury:DIR[:DIVISOR]``: a Middlebury scene folder, or a folder of them: the 2005/2006
  layout (``view1.png``, ``view5.png``, ``disp1.png``, ``disp5.png``; disparity = code /
  DIVISOR, inferred from a folder named ``third``/``half``/``full`` when not given) or the
  MiddEval3 / 2014 layout (``im0.png``, ``im1.png``, ``disp0GT.pfm``, ``mask0nocc.png``,
  ``calib.txt``);
- ``kitti:DIR[:FIRST-LAST]``: frames of a KITTI 2015 ``training/`` folder (every frame with
  ``disp_occ_0``, or those from FIRST to LAST);
- ``skimage:motorcycle``: Middlebury 2014 *Motorcycle* as scikit-image ships it
  (:func:`skimage.data.stereo_motorcycle`, no download);
- ``sceneflow:DIR``, ``crestereo:DIR``, ``fsd:DIR``: every sample with ground truth of a tree in
  FlyingThings3D's, CREStereo's or FoundationStereo's layout (a user's own data, a download, or a
  stereoforge dataset of that format), found and read by the layout
  (:meth:`synth.formats.base.Layout.discover`, :meth:`~synth.formats.base.Layout.read_key`).

The Middlebury 2014 and KITTI scenes are read by the ``middlebury`` and ``kitti`` layouts too.

Each scene becomes a pair folder ``pairs/real/<scene>/`` of the validate folder, in the layout
of the synthetic ones (:mod:`synth.validate.pairs`): ``im0.png``, ``im1.png``, ``disp0GT.pfm``,
``mask0nocc.png``, the region masks, ``sample.json``, ``files.json``, so the matcher and the
references run on it and it is scored per region like any pair (rows with ``axis = real``).
The regions follow the synthetic definitions (:func:`matcher.regions.region_masks`) on the
scene's own images: non-occluded from the scene's mask (MiddEval3's ``mask0nocc.png``,
KITTI's ``disp_noc_0``) or else a left-right check of its ground truths
(:func:`matcher.regions.occlusion_from_disparities`: with ``disp5.png``, or the left ground
truth warped to the right view); textureless from the real left image (which carries its
camera's noise); discontinuities from the ground truth. The search range is
:func:`synth.validate.pairs.max_disparity_for` of the ground truth, as for synthetic pairs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from stereoforge.errors import ParameterError

__all__ = ["AXIS", "SCHEMES", "LAYOUT_SCHEMES", "RealSpec", "resolve_real", "write_real_folder"]

#: The ``axis`` of real scenes' rows.
AXIS = "real"
_VERSION = 1
#: The schemes of a SPEC whose trees a layout of :mod:`synth.formats` reads as it is.
LAYOUT_SCHEMES = ("sceneflow", "crestereo", "fsd")
#: Every scheme of a SPEC.
SCHEMES = ("middlebury", "kitti", "skimage", *LAYOUT_SCHEMES)
_FORMS = ("middlebury:DIR[:DIVISOR], kitti:DIR[:FIRST-LAST], skimage:motorcycle, sceneflow:DIR, "
          "crestereo:DIR or fsd:DIR")
#: The layout (:func:`synth.formats.get_layout`) reading each kind of scene.
_LAYOUT_OF = {"middlebury2014": "middlebury", "kitti2015": "kitti",
              **{s: s for s in LAYOUT_SCHEMES}}


@dataclasses.dataclass(frozen=True)
class RealSpec:
    """One real scene of a run.

    Attributes
    ----------
    source : str
        The ``--real`` SPEC it came from.
    scene : str
        ``middlebury:third/Moebius``, ``kitti:training/000007``, ``skimage:motorcycle``: the
        ``scene`` column of results.csv.
    kind : str
        ``middlebury2005``, ``middlebury2014``, ``kitti2015``, ``skimage``, or a layout's name
        (``sceneflow``, ``crestereo``, ``fsd``).
    path : str
        The scene folder (the KITTI root), or ``motorcycle``.
    index : int or None
        KITTI frame.
    divisor : float or None
        Middlebury 2005/2006 codes per pixel.
    key : str or None
        The sample in a layout's tree (:meth:`synth.formats.base.Layout.read_key`).
    note : str or None
        Worth telling the user (where an inferred divisor came from).
    fingerprint : str
        SHA-256 of the loaded images and ground truth (and of this layout's version).
    """

    source: str
    scene: str
    kind: str
    path: str
    index: int | None = None
    divisor: float | None = None
    fingerprint: str = ""
    key: str | None = None
    note: str | None = None
    axis = AXIS
    value = None
    seed = None

    @property
    def folder(self) -> str:
        return f"pairs/{AXIS}/" + re.sub(r"[^A-Za-z0-9]+", "_", self.scene).strip("_")

    def load(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
        """``left, right, gt, occlusion, how``: RGB uint8 images, float32 ground truth (inf =
        unknown), the occlusion mask (255/128/0) and how it was made."""
        from matcher.io import StereoSample, load_middlebury_2005
        from synth.formats import get_layout
        from synth.formats.base import fill_occlusion

        if self.kind == "skimage":
            import skimage.data

            left, right, disp = skimage.data.stereo_motorcycle()
            gt = np.where(np.isfinite(disp), disp, np.inf).astype(np.float32)
            sample = StereoSample(left, right, gt, None, "motorcycle")
        elif self.kind in _LAYOUT_OF:
            key = self.key or ("." if self.index is None else f"{int(self.index):06d}")
            sample = get_layout(_LAYOUT_OF[self.kind]).read_key(Path(self.path), key)
        else:
            sample = load_middlebury_2005(self.path, divisor=self.divisor)
        left, right = (np.repeat(v[..., None], 3, axis=2) if v.ndim == 2 else v
                       for v in (sample.left, sample.right))
        gt = sample.disp_left.astype(np.float32)
        mask, how = fill_occlusion(StereoSample(left, right, gt, sample.disp_right, sample.name,
                                                mask_left=sample.mask_left))
        return left, right, gt, mask, how


def _fingerprint(spec: RealSpec) -> str:
    left, right, gt, mask, _ = spec.load()
    digest = hashlib.sha256(f"{spec.scene}\n{spec.kind}\n{_VERSION}\n".encode())
    for array in (left, right, gt, mask):
        digest.update(f"{array.shape}{array.dtype}".encode())
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()


def _bad(spec: str, why: str) -> ParameterError:
    return ParameterError(f"--real {spec!r}: {why}")


def _middlebury(spec: str, rest: str) -> list[RealSpec]:
    path, divisor = rest, None
    head, _, tail = rest.rpartition(":")
    if head and not Path(rest).is_dir():  # DIR:DIVISOR
        path = head
        try:
            divisor = float(tail)
        except ValueError:
            divisor = math.nan
        if not (math.isfinite(divisor) and divisor > 0):
            raise _bad(spec, f"DIVISOR must be a number > 0 (disparity = code / DIVISOR: 3 at "
                             f"third size), got {tail!r}")
    root = Path(path)
    if not root.is_dir():
        raise _bad(spec, f"{root} is not a folder; give a Middlebury scene folder or a folder "
                         "of them")

    def layout(folder: Path) -> str | None:
        if (folder / "im0.png").is_file():
            return "middlebury2014"
        return "middlebury2005" if (folder / "view1.png").is_file() else None

    folders = [root] if layout(root) else sorted(p for p in root.iterdir()
                                                 if p.is_dir() and layout(p))
    if not folders:
        raise _bad(spec, f"no Middlebury scene in {root} (a scene folder holds view1.png, "
                         "view5.png, disp1.png (2005/2006) or im0.png, im1.png, disp0GT.pfm "
                         "(2014/MiddEval3))")
    out = []
    for folder in folders:
        kind = layout(folder)
        d = divisor
        if kind == "middlebury2014" and d is not None:
            raise _bad(spec, f"{folder} is in the 2014/MiddEval3 layout (im0.png), whose ground "
                             f"truth is in pixels: it takes no DIVISOR; drop ':{tail}'")
        names = ("disp0GT.pfm", "disp0.pfm") if kind == "middlebury2014" else ("disp1.png",)
        if not any((folder / n).is_file() for n in names):
            raise _bad(spec, f"{folder} has no ground truth: no {' or '.join(names)}"
                             + (" (MiddEval3 or 2014 archive name)" if len(names) > 1 else "")
                             + "; add it or give another scene")
        note = None
        if kind == "middlebury2005" and d is None:
            d, note = _divisor(spec, folder)
        name = f"{folder.parent.name}/{folder.name}"
        out.append(RealSpec(spec, f"middlebury:{name}", kind, str(folder), divisor=d, note=note))
    return out


def _divisor(spec: str, folder: Path) -> tuple[float, str | None]:
    """The divisor of a Middlebury 2005/2006 scene from the nearest folder whose whole name
    says its size, checked against its image size; and a note naming that folder when it is
    more than a couple of levels above the scene."""
    from matcher.io import check_middlebury_2005_divisor, find_middlebury_2005_divisor, read_image

    try:
        source = find_middlebury_2005_divisor(folder)
    except ValueError:
        raise _bad(spec, f"cannot tell the disparity divisor of {folder} (no folder named "
                         "third, half or full, or ThirdSize, HalfSize or FullSize); give it: "
                         "middlebury:DIR:3 (third size), :2 (half) or :1 (full)") from None
    try:
        check_middlebury_2005_divisor(source, read_image(folder / "view1.png").shape,
                                      scene_dir=folder, fix="give it: middlebury:DIR:{divisor:g}")
    except ValueError as exc:
        raise _bad(spec, str(exc).removeprefix("divisor: ")) from None
    note = None
    if source.far:
        note = (f"middlebury:{folder.parent.name}/{folder.name}: divisor {source.divisor:g} from "
                f"the folder {source.folder} ({source.levels} levels above the scene)")
    return source.divisor, note


def _kitti(spec: str, rest: str) -> list[RealSpec]:
    path, first, last = rest, 0, 999999
    head, _, tail = rest.rpartition(":")
    found = head and not Path(rest).is_dir()  # DIR:FIRST-LAST
    if found:
        bounds = re.fullmatch(r"([0-9]+)-([0-9]+)", tail)
        if bounds is None or int(bounds.group(1)) > int(bounds.group(2)):
            raise _bad(spec, f"FIRST-LAST must be two frame numbers, FIRST <= LAST (e.g. 0-9), "
                             f"got {tail!r}")
        path, first, last = head, int(bounds.group(1)), int(bounds.group(2))
    root = Path(path)
    if not (root / "image_2").is_dir():
        raise _bad(spec, f"{root} is not a KITTI 2015 training folder (no image_2/); give "
                         "the folder holding image_2/, image_3/ and disp_occ_0/")
    frames = sorted(int(p.name[:6]) for p in (root / "disp_occ_0").glob("[0-9]" * 6 + "_10.png"))
    frames = [i for i in frames if first <= i <= last]
    if not frames:
        raise _bad(spec, f"no KITTI frame with disp_occ_0/NNNNNN_10.png in {root}"
                         + (f" between {first} and {last}" if found else ""))
    return [RealSpec(spec, f"kitti:{root.name}/{i:06d}", "kitti2015", str(root), index=i)
            for i in frames]


def _layout_tree(spec: str, scheme: str, rest: str) -> list[RealSpec]:
    from synth.formats import get_layout

    layout = get_layout(scheme)
    root = Path(rest)
    if not root.is_dir():
        raise _bad(spec, f"{root} is not a folder; give the root of a tree in the "
                         f"{layout.title} layout (see docs/formats.md)")
    keys = layout.discover(root)
    if not keys:
        raise _bad(spec, f"no sample with ground truth in {root} in the {layout.title} layout "
                         "(see docs/formats.md for its tree)")
    return [RealSpec(spec, f"{scheme}:{root.name}/{key}", scheme, str(root), key=key)
            for key in keys]


def resolve_real(specs: Sequence[str]) -> list[RealSpec]:
    """The real scenes of ``--real`` SPECs, in the given order, each with its fingerprint.

    Raises
    ------
    ParameterError
        A SPEC that is not one of the forms, a missing folder, no scene found, a scene given twice.
    """
    found: list[RealSpec] = []
    for spec in specs:
        kind, sep, rest = str(spec).partition(":")
        if kind == "middlebury" and rest:
            found += _middlebury(spec, rest)
        elif kind == "kitti" and rest:
            found += _kitti(spec, rest)
        elif kind in LAYOUT_SCHEMES and rest:
            found += _layout_tree(spec, kind, rest)
        elif kind == "skimage" and rest == "motorcycle":
            found.append(RealSpec(spec, "skimage:motorcycle", "skimage", "motorcycle"))
        else:
            raise _bad(spec, f"expected {_FORMS}")
    folders: dict[str, str] = {}
    for r in found:
        if r.folder in folders:
            raise ParameterError(f"--real: the scene {r.scene} comes twice (from "
                                 f"{folders[r.folder]!r} and {r.source!r}); give each scene once")
        folders[r.folder] = r.source
    return [dataclasses.replace(r, fingerprint=_fingerprint(r)) for r in found]


def write_real_folder(spec: RealSpec, out: Path) -> dict:
    """Write the pair folder of a real scene under ``out`` atomically; its sample record."""
    from matcher.io import atomic_write_bytes, encode_png, encode_pfm
    from matcher.regions import region_masks
    from synth.validate.pairs import commit_pair_folder, max_disparity_for

    left, right, gt, occlusion, how = spec.load()
    masks = region_masks(gt, occlusion, left)

    def write(tmp: Path) -> None:
        for name, data in (("im0.png", encode_png(left)), ("im1.png", encode_png(right)),
                           ("disp0GT.pfm", encode_pfm(gt)),
                           ("mask0nocc.png", encode_png(occlusion))):
            atomic_write_bytes(tmp / name, data, fsync=False)

    record: dict[str, Any] = {"axis": AXIS, "value": None, "seed": None, "scene": spec.scene,
                              "source": spec.source, "kind": spec.kind,
                              "fingerprint": spec.fingerprint, "occlusion": how,
                              "max_disparity": max_disparity_for(gt, gt.shape[1])}
    if spec.divisor is not None:
        record["divisor"] = spec.divisor
    if spec.note is not None:
        record["note"] = spec.note
    return commit_pair_folder(out, spec.folder, write, masks, record)
