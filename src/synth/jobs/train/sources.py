"""What ``stereoforge train`` learns from: stereoforge datasets and real scenes, as pairs with
exact ground truth and the pixels visible in both views.

A source string is one of

- a stereoforge dataset folder (``stereoforge dataset``, any format with sample folders), read
  through :class:`synth.StereoDataset`; its ``train`` split
  is learned from, its ``val`` split gives the validation loss;
- ``middlebury:DIR[:DIVISOR]``, ``kitti:DIR``, ``eth3d:DIR``, ``drivingstereo:DIR``,
  ``skimage:motorcycle``, ``sceneflow:DIR``, ``crestereo:DIR``, ``fsd:DIR`` — real scenes (or
  any tree of those layouts: :func:`synth.formats.spec_forms`), read through
  :func:`synth.validate.real.resolve_real` (as ``validate --real`` reads them); a plain path
  to such a folder is recognised too (:meth:`synth.formats.base.Layout.detect`). All of
  their scenes are learned from (no validation split). Pixels visible in both views come from the
  scene's own mask, else from a left-right check of its ground truths (the left one warped to
  the right view when there is no right one: :func:`matcher.regions.occlusion_from_disparities`).

Every source has a name and a hash: a dataset's config name and ``config_hash`` (from
``dataset.json``), a real source's spec and the SHA-256 of the arrays read. They go into the
model file's header and the checkpoint (a resumed run refuses sources that changed).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from stereoforge.errors import DatasetError, ParameterError

__all__ = ["TrainPair", "TrainSource", "open_source", "open_sources"]


@dataclass(frozen=True, eq=False)
class TrainPair:
    """One pair as the trainer uses it.

    Attributes
    ----------
    left, right : (H, W) float32 arrays
        Standardised grey views (:func:`matcher.learned.standardise`).
    disp : (H, W) float32 array
        Left ground truth, 0 where unknown (see ``visible``).
    visible : (H, W) bool array
        Pixels with ground truth that are visible in both views.
    """

    left: np.ndarray
    right: np.ndarray
    disp: np.ndarray
    visible: np.ndarray

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (self.left, self.right, self.disp, self.visible))


def _pair(left: np.ndarray, right: np.ndarray, disp: np.ndarray, mask: np.ndarray) -> TrainPair:
    from matcher.learned import standardise

    known = np.isfinite(disp) & (mask == 255)
    return TrainPair(standardise(left), standardise(right),
                     np.where(known, disp, 0.0).astype(np.float32), known)


@dataclass(eq=False)
class TrainSource:
    """One source string, opened: its pairs are loaded on demand (:meth:`load`).

    Attributes
    ----------
    spec : str
        As given.
    name, hash : str
        For the model header (see the module docstring).
    kind : str
        ``"dataset"`` or a real kind (``middlebury``, ``kitti``, ``skimage``).
    n_train, n_val : int
        Pairs in the training and validation splits.
    """

    spec: str
    name: str
    hash: str
    kind: str
    n_train: int
    n_val: int
    _splits: dict = field(default_factory=dict, repr=False)
    #: The smallest image side, (height, width), over every pair (None: not known).
    smallest: tuple[int, int] | None = None
    #: What the user should know of the source (where a real scene's divisor came from).
    notes: tuple[str, ...] = ()

    def load(self, split: str, item: int) -> TrainPair:
        """Pair ``item`` (``0 .. n_train - 1`` or ``0 .. n_val - 1``) of ``split``.

        Raises
        ------
        DatasetError
            A file of the sample is missing, truncated or corrupt: the message names the
            sample and the file.
        """
        data = self._splits[split]
        if isinstance(data, list):
            return data[item]
        try:
            s = data.sample(item)  # read back by its layout, with its occlusion mask
        except (ValueError, FileNotFoundError) as exc:  # FormatError, DatasetError, a lost file
            text = " ".join(str(exc).split())
            raise DatasetError(f"training data {self.spec}: {self.describe(split, item)}: {text}; "
                               f"check it with `stereoforge dataset --verify {self.spec}` and "
                               "render it again") from None
        return _pair(s.left, s.right, s.disp_left, s.mask_left)

    def describe(self, split: str, item: int) -> str:
        """``sample 3`` (a dataset's sample index) or ``scene 2`` of a real source."""
        data = self._splits[split]
        if isinstance(data, list):
            return f"scene {item}"
        return f"sample {data.indices[item]} ({split} item {item})"

    def header(self) -> dict:
        return {"spec": self.spec, "name": self.name, "hash": self.hash, "kind": self.kind,
                "train_pairs": self.n_train, "val_pairs": self.n_val}


def _dataset(spec: str, root: Path, val_fraction: float) -> TrainSource:
    from synth.dataset.loader import StereoDataset

    from synth._util.json_records import read_json_object

    everything = StereoDataset(root)  # checks the layout, the format, that samples exist
    header = read_json_object(root / "dataset.json", what="dataset header")
    splits: dict = {}
    for split in ("train", "val"):
        try:
            splits[split] = StereoDataset(root, split=split, val_fraction=val_fraction)
        except DatasetError:  # an empty split
            splits[split] = []
    if not splits["train"]:
        raise DatasetError(f"{root}: all {len(everything)} samples are in the validation split "
                           f"(val_fraction {val_fraction}); render more samples")
    rig = header.get("config", {}).get("rig", {}) if isinstance(header.get("config"), dict) else {}
    size = (rig.get("height"), rig.get("width")) if isinstance(rig, dict) else (None, None)
    smallest = size if all(isinstance(v, int) for v in size) else None
    return TrainSource(spec, str(header.get("name", root.name)), str(header.get("config_hash", "")),
                       "dataset", len(splits["train"]), len(splits["val"]), splits, smallest)


def _real(spec: str) -> TrainSource:
    from synth.validate.real import resolve_real

    try:
        scenes = resolve_real([spec])
    except ParameterError as exc:
        raise DatasetError(f"training data {str(exc).removeprefix('--real ')}") from None
    pairs, digest = [], hashlib.sha256()
    for scene in scenes:
        left, right, gt, mask, _how = scene.load()
        if not np.isfinite(gt).any():
            raise DatasetError(f"{spec}: scene {scene.scene} has no ground truth; train needs "
                               "ground-truth disparities")
        digest.update(scene.fingerprint.encode())
        pairs.append(_pair(left, right, gt, mask))
    smallest = (min(p.left.shape[0] for p in pairs), min(p.left.shape[1] for p in pairs))
    return TrainSource(spec, spec, digest.hexdigest(), spec.partition(":")[0], len(pairs), 0,
                       {"train": pairs, "val": []}, smallest,
                       tuple(s.note for s in scenes if s.note is not None))


_IMAGES_ONLY = ("im0.png", "view1.png", "image_2", "training/image_2")


def open_source(spec: str, *, val_fraction: float = 0.1) -> TrainSource:
    """Open one source string (see the module docstring).

    Raises
    ------
    DatasetError
        A folder that is neither a stereoforge dataset nor a real-scene folder, a dataset
        without samples, a scene without ground truth.
    FileNotFoundError
        No such path.
    """
    from synth.formats import spec_forms
    from synth.formats.base import Layout

    forms = spec_forms()
    if spec.partition(":")[0] in forms and ":" in spec:
        return _real(spec)
    root = Path(spec).expanduser()
    if not root.exists():
        raise FileNotFoundError(f"training data {spec}: no such folder; give a stereoforge "
                                "dataset (stereoforge dataset CONFIG --out DIR) or "
                                f"{', '.join(forms.values())}")
    if (root / "dataset.json").is_file():
        return _dataset(spec, root, val_fraction)
    layout = Layout.detect(root)
    if layout is not None and layout.scheme is not None:
        return _real(f"{layout.scheme}:{spec}")
    if any((root / n).exists() or any(root.glob(f"*/{n}")) for n in _IMAGES_ONLY):
        raise DatasetError(f"training data {spec}: {root} holds stereo images but no ground-truth "
                           "disparity (disp0GT.pfm, disp1.png or disp_occ_0/); train learns from "
                           "ground truth: give a stereoforge dataset or a training folder")
    raise DatasetError(f"training data {spec}: {root} is neither a stereoforge dataset (no "
                       "dataset.json) nor a folder of real scenes with ground truth (no "
                       "view1.png + disp1.png, im0.png + disp0GT.pfm, disp_occ_0/, "
                       "two_view_training/, disparity_maps/, ...); or name its layout: "
                       f"{', '.join(forms.values())}")


def open_sources(specs: list[str] | tuple[str, ...], *, val_fraction: float = 0.1
                 ) -> list[TrainSource]:
    """Open every source string; at least one is needed."""
    if not specs:
        raise DatasetError("train: give at least one DATASET")
    return [open_source(str(s), val_fraction=val_fraction) for s in specs]
