"""``StereoDataset``: a dataset directory as a map-style training dataset (numpy only).

``StereoDataset(DIR)[i]`` is a dict of numpy arrays, so a torch ``DataLoader`` takes it as it is
(``len``, integer indexing, picklable for worker processes) without torch being a dependency::

    from torch.utils.data import DataLoader
    from synth import StereoDataset
    train = DataLoader(StereoDataset("out/planes", split="train"), batch_size=8, num_workers=4)

The split is decided per sample from its seed (``seed / 2**63 < val_fraction``: validation), so it
is deterministic, independent of the order and of the count (a sample stays in its split when the
dataset is extended), and close to ``val_fraction`` for more than a few dozen samples.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from matcher.io import StereoSample
from stereoforge.errors import DatasetError
from stereoforge.validation import check_choice, check_real
from synth._util.json_records import read_json_object
from synth.dataset.storage.layout import check_layout
from synth.dataset.storage.manifest import MODIFIED_FIX, read_manifest
from synth.formats import DATASET_FORMATS, FORMATS, get_layout

__all__ = ["StereoDataset", "SPLITS", "is_validation"]

#: Accepted ``split`` values.
SPLITS = ("all", "train", "val")
_SEED_RANGE = 2**63  # sample seeds are uint64 >> 1 (synth.dataset.config.sampling.sample_seed)


def is_validation(seed: int, val_fraction: float) -> bool:
    """Whether the sample of ``seed`` belongs to the validation split.

    Examples
    --------
    >>> is_validation(0, 0.1), is_validation(2**62, 0.1), is_validation(2**62, 0.6)
    (True, False, True)
    """
    return int(seed) < val_fraction * _SEED_RANGE


def _records(root: Path) -> list[dict]:
    return read_manifest(root)  # the complete samples' sample.json (not a possibly stale manifest)


class StereoDataset:
    """The samples of a dataset directory made by :func:`synth.run_dataset`.

    Parameters
    ----------
    root : str or Path
        The dataset directory, of any format with sample folders (``middlebury``,
        ``middlebury2014``, ``kitti``, ``sceneflow``, ``crestereo``, ``fsd``: every layout but
        ``webdataset``), read through its layout (:mod:`synth.formats`).
    split : {"all", "train", "val"}
        ``val``: the samples whose seed falls in the first ``val_fraction`` of the seed range;
        ``train``: the others.
    val_fraction : float
        In ``[0, 1]``.

    Attributes
    ----------
    root : Path
    format : str
    layout : synth.formats.base.Layout
    indices : tuple of int
        The dataset's sample indices in this split, sorted; item ``i`` is sample ``indices[i]``.

    Notes
    -----
    ``dataset[i]`` is a dict:

    - ``left``, ``right``: (H, W, 3) uint8 RGB;
    - ``disp``: (H, W) float32 left disparity in pixels, ``inf`` where there is no ground truth;
    - ``valid``: (H, W) bool, finite ``disp``;
    - ``occlusion``: (H, W) bool, pixels of the left view hidden in the right one (they have a
      ground-truth disparity; ``mask0nocc.png`` 128, or valid in ``disp_occ_0`` only; a layout
      without a mask: a left-right check of its ground truths,
      :func:`synth.formats.reading.fill_occlusion`);
    - ``calib``: dict of float64 ``fx``, ``fy``, ``cx``, ``cy`` (pixels) and ``baseline`` (m);
    - ``index``, ``seed``: int64 scalars of the sample;
    - when on disk: ``disp_right`` ((H, W) float32: Middlebury ``disp1GT.pfm`` or
      ``disp1.pfm``, SceneFlow's right PFM, CREStereo's ``_right.disp.png``), and the optional ground truth of :mod:`synth.write.extra_ground_truth`: ``depth``
      ((H, W) float32 metres), ``normals`` ((H, W, 3) float32), ``instance`` ((H, W) uint16),
      ``semantic`` ((H, W) uint8), ``occlusion_right`` ((H, W) bool, the right view's pixels
      hidden in the left).

    Raises
    ------
    DatasetError
        ``root`` holds no dataset, a dataset of the previous layout (the message names
        ``stereoforge dataset --upgrade DIR``), a format without sample folders, or no sample in
        the split; and, from ``dataset[i]``, a sample whose files are missing, damaged, not
        regular files, outside the dataset, or disagree in size or channels (the message names
        the sample and the file). An index out of range is an ``IndexError``, a non-integer
        index a ``TypeError``, as for any sequence.

    Examples
    --------
    >>> import tempfile
    >>> from synth import run_dataset
    >>> tmp = tempfile.mkdtemp()
    >>> _ = run_dataset("planes", out=f"{tmp}/planes", count=3, progress=False)
    >>> data = StereoDataset(f"{tmp}/planes")
    >>> len(data), sorted(data[0])
    (3, ['calib', 'disp', 'disp_right', 'index', 'left', 'occlusion', 'right', 'seed', 'valid'])
    >>> data[0]["left"].shape, data[0]["disp"].dtype
    ((480, 640, 3), dtype('float32'))
    """

    def __init__(self, root: str | Path, *, split: str = "all", val_fraction: float = 0.1) -> None:
        check_choice(split, "split", SPLITS)
        check_real(val_fraction, "val_fraction", lo=0.0, hi=1.0)
        self.root = Path(root)
        header_path = self.root / "dataset.json"
        if not header_path.is_file():
            raise DatasetError(f"{self.root} has no dataset.json; pass a directory made by "
                               "run_dataset (stereoforge dataset)")
        check_layout(self.root)
        header = read_json_object(header_path, what="dataset header", fix=MODIFIED_FIX)
        self.format = header.get("format")
        if self.format not in DATASET_FORMATS:
            raise DatasetError(f"{header_path}: unknown format {self.format!r}; StereoDataset "
                               f"reads {', '.join(DATASET_FORMATS)} datasets")
        self.layout = get_layout(self.format)
        if not self.layout.capacity.sample_folders:
            raise DatasetError(f"{header_path}: format {self.format!r} has no sample folders; "
                               f"StereoDataset reads the {', '.join(FORMATS)} formats (read "
                               f"{self.format} shards with webdataset.WebDataset)")
        self.split, self.val_fraction = split, float(val_fraction)
        self._seeds: dict[int, int] = {}
        for r in _records(self.root):
            if split == "all" or (split == "val") == is_validation(r["seed"], val_fraction):
                self._seeds[int(r["index"])] = int(r["seed"])
        self.indices = tuple(sorted(self._seeds))
        if not self.indices:
            raise DatasetError(f"{self.root}: no complete sample in split {split!r} (val_fraction "
                               f"{val_fraction}); render more samples or change val_fraction")

    def __len__(self) -> int:
        return len(self.indices)

    def __repr__(self) -> str:
        return (f"StereoDataset({str(self.root)!r}, split={self.split!r}, "
                f"val_fraction={self.val_fraction}) with {len(self)} samples ({self.format})")

    def sample(self, item: int, *, extras: bool = False) -> StereoSample:
        """Item ``item`` as the layout reads it back (:meth:`synth.formats.base.Layout.read`):
        images, left and right ground truth, the occlusion mask (255/128/0), calibration and,
        with ``extras``, the optional ground truth."""
        if isinstance(item, (bool, np.bool_)) or not isinstance(item, (int, np.integer)):
            raise TypeError(f"index: expected an int, got {type(item).__name__}")
        if not -len(self) <= item < len(self):
            raise IndexError(f"index {item} out of range for {len(self)} samples")
        index = self.indices[int(item)]
        try:
            return self.layout.read(self.root, index, extras=extras)
        except DatasetError:
            raise
        except (OSError, ValueError, KeyError, IndexError, TypeError) as exc:  # damaged files
            text = " ".join(str(exc).split())
            raise DatasetError(f"{self.root}: sample {index}: {text}; check the dataset with "
                               f"`stereoforge dataset --verify {self.root}` and render the "
                               "sample again") from None

    def __getitem__(self, item: int) -> dict[str, Any]:
        s = self.sample(item, extras=True)
        index = self.indices[int(item)]
        extra: dict[str, Any] = {}
        if s.disp_right is not None:
            extra["disp_right"] = s.disp_right.astype(np.float32, copy=False)
        extra.update(s.extras)
        if "occlusion_right" in extra:  # the right view's mask: its occluded pixels
            extra["occlusion_right"] = extra["occlusion_right"] == 128
        disp = s.disp_left.astype(np.float32, copy=False)
        return {
            "left": s.left, "right": s.right, "disp": disp, "valid": np.isfinite(disp),
            "occlusion": s.mask_left == 128,
            "calib": {k: np.float64(v) for k, v in s.calib.items()},
            "index": np.int64(index), "seed": np.int64(self._seeds[index]),
            **extra,
        }
