"""Real scenes beside the synthetic axes: ``stereoforge validate --real SPEC``.

A SPEC names real stereo pairs with ground truth; :func:`synth.formats.resolve_spec` finds them
through the layout of its scheme and each is read by that layout (:mod:`synth.formats`):

- ``middlebury:DIR[:DIVISOR]``: a Middlebury scene folder, or a folder of them: the 2005/2006
  layout (``view1.png``, ``view5.png``, ``disp1.png``, ``disp5.png``; disparity = code /
  DIVISOR, inferred from the nearest folder whose whole name is ``third``/``half``/``full``
  when not given, and checked against the image size) or the MiddEval3 / 2014 layout
  (``im0.png``, ``im1.png``, ``disp0GT.pfm``, ``mask0nocc.png``, ``calib.txt``);
- ``kitti:DIR[:FIRST-LAST]``: frames of a KITTI 2015 ``training/`` folder (every frame with
  ``disp_occ_0``, or those from FIRST to LAST);
- ``eth3d:DIR``: the ETH3D two-view training scenes (``two_view_training/`` and
  ``two_view_training_gt/``);
- ``drivingstereo:DIR``: DrivingStereo frames (``left_images/``, ``right_images/``,
  ``disparity_maps/``, or the archives' names);
- ``skimage:motorcycle``: Middlebury 2014 *Motorcycle* as scikit-image ships it
  (:func:`skimage.data.stereo_motorcycle`, no download);
- ``sceneflow:DIR``, ``crestereo:DIR``, ``fsd:DIR``: every sample with ground truth of a tree in
  FlyingThings3D's, CREStereo's or FoundationStereo's layout (a user's own data, a download, or a
  stereoforge dataset of that format).

Each scene becomes a pair folder ``pairs/real/<scene>/`` of the validate folder, in the layout
of the synthetic ones (:mod:`synth.validate.pairs`): ``im0.png``, ``im1.png``, ``disp0GT.pfm``,
``mask0nocc.png``, the region masks, ``sample.json``, ``files.json``, so the matcher and the
references run on it and it is scored per region like any pair (rows with ``axis = real``).
The regions follow the synthetic definitions (:func:`matcher.regions.region_masks`) on the
scene's own images: non-occluded from the scene's mask (MiddEval3's and ETH3D's
``mask0nocc.png``, KITTI's ``disp_noc_0``) or else a left-right check of its ground truths
(:func:`matcher.regions.occlusion_from_disparities`: with ``disp5.png``, or the left ground
truth warped to the right view); textureless from the real left image (which carries its
camera's noise); discontinuities from the ground truth. The search range is
:func:`synth.validate.pairs.max_disparity_for` of the ground truth, as for synthetic pairs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from stereoforge.errors import ParameterError

if TYPE_CHECKING:
    from synth.formats.base import SceneRef

__all__ = ["AXIS", "RealSpec", "resolve_real", "set_names", "write_real_folder"]

#: The ``axis`` of real scenes' rows.
AXIS = "real"
_VERSION = 1


@dataclasses.dataclass(frozen=True)
class RealSpec:
    """One real scene of a run.

    Attributes
    ----------
    source : str
        The ``--real`` SPEC it came from.
    ref : synth.formats.base.SceneRef
        The scene, as its layout reads it.
    fingerprint : str
        SHA-256 of the loaded images and ground truth (and of this layout's version).
    """

    source: str
    ref: SceneRef
    fingerprint: str = ""
    axis = AXIS
    value = None
    seed = None

    @property
    def scene(self) -> str:
        """``middlebury:third/Moebius``, ``kitti:training/000007``, ``eth3d:delivery_area_1s``:
        the ``scene`` column of results.csv."""
        return self.ref.scene

    @property
    def kind(self) -> str:
        """``middlebury2005``, ``middlebury2014``, ``kitti2015``, ``eth3d``, ... (the layout's
        :attr:`~synth.formats.base.Layout.kind`)."""
        return self.ref.kind

    @property
    def divisor(self) -> float | None:
        """Middlebury 2005/2006 codes per pixel."""
        return self.ref.divisor

    @property
    def note(self) -> str | None:
        """Worth telling the user (where an inferred divisor came from)."""
        return self.ref.note

    @property
    def folder(self) -> str:
        return f"pairs/{AXIS}/" + re.sub(r"[^A-Za-z0-9]+", "_", self.scene).strip("_")

    def load(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
        """``left, right, gt, occlusion, how``: RGB uint8 images, float32 ground truth (inf =
        unknown), the occlusion mask (255/128/0) and how it was made."""
        from matcher.io import StereoSample
        from synth.formats.reading import fill_occlusion

        sample = self.ref.read()
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


def set_names(specs: Sequence[str]) -> list[str]:
    """The name of each ``--real`` SPEC's set in results: its scheme, ``-2``, ``-3`` ... for a
    second, third SPEC of one scheme.

    Examples
    --------
    >>> set_names(["eth3d:a", "kitti:b", "eth3d:c"])
    ['eth3d', 'kitti', 'eth3d-2']
    """
    names: list[str] = []
    out = []
    for spec in specs:
        scheme = str(spec).partition(":")[0]
        out.append(scheme if scheme not in names else f"{scheme}-{names.count(scheme) + 1}")
        names.append(scheme)
    return out


def resolve_real(specs: Sequence[str]) -> list[RealSpec]:
    """The real scenes of ``--real`` SPECs, in the given order, each with its fingerprint.

    Raises
    ------
    ParameterError
        A SPEC that is not one of the forms, a missing folder, no scene found, a scene given twice.
    """
    from synth.formats import resolve_spec

    found: list[RealSpec] = []
    for spec in specs:
        try:
            found += [RealSpec(str(spec), ref) for ref in resolve_spec(str(spec))]
        except ParameterError as exc:
            raise ParameterError(f"--real {exc}") from None
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
