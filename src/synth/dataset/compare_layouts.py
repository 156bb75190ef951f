"""Compare two datasets of different layouts sample by sample: the same pixels, the same ground
truth within each layout's quantum (``stereoforge dataset --compare A B`` across formats).

Files of two layouts cannot be compared one by one (``training/image_2/000003_10.png`` against
``MiddEval3/trainingF/000003/im0.png``), so each sample is read back by its layout
(:meth:`synth.formats.base.Layout.read`) and compared as arrays:

- **images**: equal pixels. Where one layout stores JPEG (:attr:`Capacity.lossless
  <synth.formats.base.Capacity.lossless>` false), the other's images are encoded with the same
  deterministic JPEG encoder first (:func:`matcher.io.encode_jpeg` at
  :data:`synth.formats.base.JPEG_QUALITY`), so a JPEG layout compares exactly too;
- **ground truth**: the same pixels without ground truth (``inf``), and every other disparity
  within the coarser layout's quantum (KITTI 1/256 px, CREStereo 1/32, FSD 1/1000, float32: 0);
  the right view's where both layouts hold it;
- **calibration**: equal ``fx``, ``fy``, ``cx``, ``cy``, ``baseline``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from synth.dataset.compare import Difference

__all__ = ["compare_layouts", "dataset_formats"]


def dataset_formats(a: Path, b: Path) -> tuple[str, str] | None:
    """The formats of two dataset folders when both have a ``dataset.json`` and they differ."""
    from synth.dataset.storage.layout import dataset_format

    if not ((a / "dataset.json").is_file() and (b / "dataset.json").is_file()):
        return None
    fa, fb = dataset_format(a), dataset_format(b)
    return None if fa == fb else (fa, fb)


def _indices(root: Path) -> set[int]:
    from synth.dataset.storage.manifest import read_manifest

    return {int(r["index"]) for r in read_manifest(root)}


def _jpeg(image: np.ndarray) -> np.ndarray:
    import cv2

    from matcher.io import encode_jpeg
    from synth.formats.base import JPEG_QUALITY

    decoded = cv2.imdecode(np.frombuffer(encode_jpeg(image, quality=JPEG_QUALITY), np.uint8),
                           cv2.IMREAD_UNCHANGED)
    return decoded[..., ::-1] if decoded.ndim == 3 else decoded


def _image_detail(a: np.ndarray, b: np.ndarray, what: str) -> str | None:
    if a.shape != b.shape:
        return f"{what}: shapes {a.shape} and {b.shape}"
    differ = np.any(a != b, axis=-1) if a.ndim == 3 else a != b
    if not differ.any():
        return None
    r, c = (int(i) for i in np.argwhere(differ)[0])
    gap = np.abs(a.astype(np.int16) - b.astype(np.int16)).max()
    return (f"{what}: {int(differ.sum())} of {differ.size} pixels differ, largest |difference| "
            f"{gap}; first at row {r}, column {c}")


def _disparity_detail(a: np.ndarray, b: np.ndarray, what: str, tolerance: float) -> str | None:
    if a.shape != b.shape:
        return f"{what}: shapes {a.shape} and {b.shape}"
    fa, fb = np.isfinite(a), np.isfinite(b)
    if (fa != fb).any():
        n = int((fa != fb).sum())
        r, c = (int(i) for i in np.argwhere(fa != fb)[0])
        return (f"{what}: {n} pixels have ground truth in one layout only; first at row {r}, "
                f"column {c}: {a[r, c]:g} vs {b[r, c]:g}")
    gap = np.abs(a[fa].astype(np.float64) - b[fa].astype(np.float64))
    if gap.size and gap.max() > tolerance:
        return (f"{what}: {int((gap > tolerance).sum())} disparities differ by more than the "
                f"quantum {tolerance:g} px (largest {gap.max():g} px)")
    return None


def compare_layouts(a: str | Path, b: str | Path) -> list[Difference]:
    """Sample-by-sample differences of two datasets of different layouts (module docstring).

    Returns
    -------
    list of Difference
        One per sample that differs (``path`` is the sample's six-digit index; kind
        ``content``, ``only_a`` or ``only_b``), in index order; empty when every sample holds the
        same data.
    """
    from synth.dataset.storage.layout import dataset_format
    from synth.formats import get_layout

    roots = [Path(a), Path(b)]
    layouts = [get_layout(dataset_format(r)) for r in roots]
    for name, layout in zip("AB", layouts):
        if not layout.capacity.sample_folders:
            raise ValueError(f"{name}: a {layout.name} dataset has no sample folders to compare "
                             "across layouts; compare it with a dataset of the same format")
    ia, ib = (_indices(r) for r in roots)
    out = [Difference(f"{i:06d}", "only_a", f"sample {i} only in A") for i in sorted(ia - ib)]
    out += [Difference(f"{i:06d}", "only_b", f"sample {i} only in B") for i in sorted(ib - ia)]
    lossy = not all(layout.capacity.lossless for layout in layouts)
    tolerance = max(layout.capacity.disp_quantum or 0.0 for layout in layouts)
    for index in sorted(ia & ib):
        sa, sb = (layout.read(root, index) for layout, root in zip(layouts, roots))
        details = []
        for what, x, y in (("left image", sa.left, sb.left), ("right image", sa.right, sb.right)):
            if lossy:  # the lossless side as the JPEG layout stores it; JPEG pixels as they are
                x = x if not layouts[0].capacity.lossless else _jpeg(x)
                y = y if not layouts[1].capacity.lossless else _jpeg(y)
            details.append(_image_detail(x, y, what))
        details.append(_disparity_detail(sa.disp_left, sb.disp_left, "left disparity", tolerance))
        if sa.disp_right is not None and sb.disp_right is not None:
            details.append(_disparity_detail(sa.disp_right, sb.disp_right, "right disparity",
                                             tolerance))
        if sa.calib != sb.calib:
            details.append(f"calibration: {sa.calib} vs {sb.calib}")
        found = [d for d in details if d]
        if found:
            out.append(Difference(f"{index:06d}", "content", "; ".join(found)))
    return sorted(out, key=lambda d: d.path)
