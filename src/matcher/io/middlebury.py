"""The Middlebury stereo layouts: read 2005/2006 and 2014 scenes, write 2014 scenes.

Middlebury 2005/2006 (read): ``view1.png``, ``view5.png`` (left, right), ``disp1.png``,
``disp5.png`` (8-bit disparity codes, ``code / divisor`` pixels, 0 = unknown).

Middlebury 2014 / MiddEval3 (read and write; see ``docs/formats.md``), ``layout="middeval3"``::

    im0.png, im1.png     left and right images (8-bit, RGB or grey)
    im1E.png, im1L.png   the right image under other exposure / lighting in real Middlebury 2014
                         scenes; written as given, else as hard links to im1.png (its bytes
                         stored once; copies where the file system has no hard links;
                         RAFT-Stereo lists them)
    disp0GT.pfm          left ground-truth disparity, float32, inf = no ground truth (MiddEval3's
                         name, what the SDK's runeval and RAFT-Stereo's Middlebury loader read)
    disp1GT.pfm          right ground truth
    mask0nocc.png        occlusion mask of the left view: 255 visible, 128 occluded, 0 no GT
    mask0spec.png        ours, written when given: specular highlights of the left view (255)
    mask1spec.png        ... and of the right view
    mask0sky.png         ours, written when given: the left view's sky at infinity (255; its
                         disparity is 0 in disp0GT.pfm)
    calib.txt            cam0, cam1, doffs, baseline (mm), width, height, ndisp, isint, vmin, vmax

``layout="2014"`` writes the same files with the ground truth under the names of the 2014 scene
archives (``Adirondack-perfect/disp0.pfm``, ``disp1.pfm``; RAFT-Stereo's ``split="2014"`` reads
``disp0.pfm``). Both are read, and so are scenes stereoforge wrote before the MiddEval3 names.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from matcher._validation import (check_choice, check_ground_truth, check_occlusion_mask,
                                 check_positive)
from matcher.io.atomic import write_all_atomic
from matcher.io.calib import format_calib, read_calib
from matcher.io.pfm import encode_pfm
from matcher.io.png import check_deflate, encode_png, read_disparity, read_image
from matcher.io.sample import StereoSample, check_sample_shapes, check_stereo_images, require_dir

__all__ = [
    "GT_FILES",
    "GT_NAMES",
    "REQUIRED_CALIB_KEYS",
    "SIZE_FOLDERS",
    "DivisorSource",
    "check_middlebury_2005_divisor",
    "divisor_of_shape",
    "find_middlebury_2005_divisor",
    "infer_middlebury_2005_divisor",
    "load_middlebury_2005",
    "load_middlebury_2014",
    "write_middlebury",
]

#: Keys ``calib`` must provide; ``width``, ``height``, ``isint``, ``vmin``, ``vmax`` are filled in
#: if absent.
REQUIRED_CALIB_KEYS: tuple[str, ...] = ("cam0", "cam1", "doffs", "baseline", "ndisp")

#: Ground-truth file names (left, right) of each scene layout :func:`write_middlebury` writes:
#: MiddEval3's (its SDK, RAFT-Stereo's ``split="F"``) and the 2014 scene archives' (RAFT-Stereo's
#: ``split="2014"``; what stereoforge wrote before the MiddEval3 names).
GT_FILES: dict[str, tuple[str, str]] = {"middeval3": ("disp0GT.pfm", "disp1GT.pfm"),
                                        "2014": ("disp0.pfm", "disp1.pfm")}
#: Ground-truth file names the reader looks for, in this order (MiddEval3's first).
GT_NAMES: dict[str, tuple[str, ...]] = {
    view: tuple(names[i] for names in GT_FILES.values()) for i, view in enumerate(("left", "right"))}

#: Folder names (compared whole, in any case) that say a Middlebury 2005/2006 scene's size, as the
#: archives and their mirrors name them, and the disparity divisor of that size.
SIZE_FOLDERS: dict[str, float] = {"third": 3.0, "thirdsize": 3.0, "half": 2.0, "halfsize": 2.0,
                                  "full": 1.0, "fullsize": 1.0}
#: Image height (pixels) of every Middlebury 2005/2006 scene, and the range of their widths, at
#: each size (divisor): 1110 and 1240-1396 at full size, a half and a third of those.
SIZE_SHAPES: dict[float, tuple[int, tuple[int, int]]] = {
    1.0: (1110, (1240, 1396)), 2.0: (555, (620, 698)), 3.0: (370, (413, 465))}
#: Levels above a scene folder beyond which the folder a divisor came from is worth saying.
NEAR_LEVELS = 2


@dataclass(frozen=True)
class DivisorSource:
    """Where a Middlebury 2005/2006 scene's divisor came from (:func:`find_middlebury_2005_divisor`).

    Attributes
    ----------
    divisor : float
        3 (third size), 2 (half) or 1 (full).
    folder : pathlib.Path
        The folder whose name says the size.
    levels : int
        How far above the scene folder it is (0: the scene folder itself, 1: its parent).
    """

    divisor: float
    folder: Path
    levels: int

    @property
    def far(self) -> bool:
        """More than :data:`NEAR_LEVELS` above the scene: a user's own folder, worth naming."""
        return self.levels > NEAR_LEVELS


def find_middlebury_2005_divisor(scene_dir: str | os.PathLike[str]) -> DivisorSource:
    """The divisor of a Middlebury 2005/2006 scene from the nearest folder whose **whole** name
    says its size (:data:`SIZE_FOLDERS`: ``third``, ``ThirdSize``, ``half``, ... in any case).

    A name that only contains one of the words (``carefully``, ``fullsets``, ``halfmoon``) says
    nothing.

    Raises
    ------
    ValueError
        If no folder name says; pass ``divisor`` explicitly then.

    Examples
    --------
    >>> find_middlebury_2005_divisor("data/ThirdSize/Moebius").divisor
    3.0
    >>> find_middlebury_2005_divisor("data/half/my/own/Moebius").levels
    3
    """
    path = Path(scene_dir)
    parts = path.resolve().parts if path.exists() else path.parts
    for levels, part in enumerate(reversed(parts)):
        divisor = SIZE_FOLDERS.get(part.lower())
        if divisor is not None:
            return DivisorSource(divisor, Path(*parts[:len(parts) - levels]), levels)
    raise ValueError(
        f"divisor: cannot infer the size variant of {path} (no folder named third, half or full, "
        "or ThirdSize, HalfSize or FullSize); pass divisor=3 (third size), 2 (half) or 1 (full)"
    )


def infer_middlebury_2005_divisor(scene_dir: str | os.PathLike[str]) -> float:
    """The divisor of :func:`find_middlebury_2005_divisor` (3, 2 or 1).

    Raises
    ------
    ValueError
        If no folder name says; pass ``divisor`` explicitly then.

    Examples
    --------
    >>> infer_middlebury_2005_divisor("data/middlebury/third/Moebius")
    3.0
    """
    return find_middlebury_2005_divisor(scene_dir).divisor


def check_middlebury_2005_divisor(source: DivisorSource, shape: tuple[int, ...], *,
                                  scene_dir: str | os.PathLike[str], fix: str) -> None:
    """Refuse a divisor inferred from a folder name that the scene's image size contradicts.

    The images of every Middlebury 2005/2006 release have a known size (:data:`SIZE_SHAPES`):
    a scene of third-size images under a ``full/`` folder is refused, with ``fix`` (formatted
    with ``divisor``, the size's divisor) as the way out. An image of no release's size (a crop,
    a resize) is not checked.

    Raises
    ------
    ValueError
        The folder's size and the image's disagree.
    """
    says = divisor_of_shape(shape)
    if says is not None and says != source.divisor:
        names = {3.0: "third", 2.0: "half", 1.0: "full"}
        raise ValueError(
            f"divisor: the folder {str(source.folder)!r} says {names[source.divisor]} size (divisor "
            f"{source.divisor:g}) for the scene {str(scene_dir)!r}, but its images are "
            f"{int(shape[1])}x{int(shape[0])}, the {names[says]} size of the Middlebury 2005/2006 "
            f"releases (divisor {says:g}); {fix.format(divisor=says)}")


def divisor_of_shape(shape: tuple[int, ...]) -> float | None:
    """The divisor a Middlebury 2005/2006 image's size says (:data:`SIZE_SHAPES`), or None for
    a size of no release (a crop, a resize).

    Examples
    --------
    >>> divisor_of_shape((370, 463, 3)), divisor_of_shape((555, 695)), divisor_of_shape((48, 64))
    (3.0, 2.0, None)
    """
    height, width = int(shape[0]), int(shape[1])
    for divisor, (h, (lo, hi)) in SIZE_SHAPES.items():
        if abs(height - h) <= 1 and lo - 2 <= width <= hi + 2:
            return divisor
    return None


def load_middlebury_2005(scene_dir: str | os.PathLike[str], *, divisor: float | None = None) -> StereoSample:
    """Load a Middlebury 2005/2006 scene (``view1.png``, ``view5.png``, ``disp1.png``, ``disp5.png``).

    Parameters
    ----------
    scene_dir : str or path-like
        Folder of one scene, e.g. ``.../middlebury/third/Moebius``.
    divisor : float, optional
        PNG codes per pixel: 3 for the third size, 2 for half, 1 for full. When None it is
        inferred from the folder names (:func:`find_middlebury_2005_divisor`) and checked
        against the image size (:func:`check_middlebury_2005_divisor`).

    Returns
    -------
    StereoSample
        ``disp_left``/``disp_right`` are ``code / divisor``, ``inf`` where the code is 0
        (unknown); ``disp_right`` is None when ``disp5.png`` is absent. ``meta`` holds
        ``dataset="middlebury2005"``, ``divisor`` and ``scene_dir``.

    Examples
    --------
    >>> import tempfile, pathlib, cv2, numpy as np
    >>> with tempfile.TemporaryDirectory() as d:
    ...     s = pathlib.Path(d, "third", "Toy"); s.mkdir(parents=True)
    ...     for n in ("view1", "view5"): _ = cv2.imwrite(str(s / f"{n}.png"), np.zeros((2, 3, 3), np.uint8))
    ...     _ = cv2.imwrite(str(s / "disp1.png"), np.array([[0, 3, 6], [9, 3, 0]], np.uint8))
    ...     load_middlebury_2005(s).disp_left[0].tolist()
    [inf, 1.0, 2.0]
    """
    scene_dir = Path(scene_dir)
    require_dir(scene_dir, "scene_dir")
    source = find_middlebury_2005_divisor(scene_dir) if divisor is None else None
    divisor = source.divisor if source is not None else check_positive(divisor, "divisor")
    left = read_image(scene_dir / "view1.png")
    if source is not None:
        check_middlebury_2005_divisor(source, left.shape, scene_dir=scene_dir,
                                      fix="pass divisor={divisor:g}")
    right = read_image(scene_dir / "view5.png")
    disp_left = read_disparity(scene_dir / "disp1.png", divisor=divisor)
    disp5 = scene_dir / "disp5.png"
    disp_right = read_disparity(disp5, divisor=divisor) if disp5.is_file() else None
    check_sample_shapes(scene_dir, left, right, disp_left, disp_right)
    meta = {"dataset": "middlebury2005", "divisor": divisor, "scene_dir": str(scene_dir)}
    return StereoSample(left, right, disp_left, disp_right, scene_dir.name, meta)


def load_middlebury_2014(scene_dir: str | os.PathLike[str]) -> StereoSample:
    """Load a Middlebury 2014 scene (either layout :func:`write_middlebury` writes).

    Reads ``im0.png``, ``im1.png``, ``disp0GT.pfm`` (MiddEval3) or ``disp0.pfm`` (the 2014 scene
    archives), and, when present, ``calib.txt``, ``disp1GT.pfm`` (``disp1.pfm``) and
    ``mask0nocc.png`` (which the 2014 archives do not have).

    Returns
    -------
    StereoSample
        Disparities as stored (``inf`` where there is no ground truth); ``meta["calib"]`` is the
        parsed ``calib.txt`` (:func:`matcher.io.read_calib`; None without one); ``mask_left``
        the occlusion mask or None.

    Examples
    --------
    >>> import tempfile, pathlib, cv2, numpy as np
    >>> from matcher.io import format_calib, write_pfm
    >>> with tempfile.TemporaryDirectory() as d:
    ...     s = pathlib.Path(d)
    ...     for n in ("im0", "im1"): _ = cv2.imwrite(str(s / f"{n}.png"), np.zeros((2, 3, 3), np.uint8))
    ...     _ = write_pfm(s / "disp0.pfm", np.array([[1, 2, np.inf], [1, 2, 3]]))
    ...     _ = (s / "calib.txt").write_text(format_calib({"cam0": np.eye(3), "ndisp": 8}))
    ...     load_middlebury_2014(s).meta["calib"]["ndisp"]
    8
    """
    scene_dir = Path(scene_dir)
    require_dir(scene_dir, "scene_dir")
    left = read_image(scene_dir / "im0.png")
    right = read_image(scene_dir / "im1.png")
    gt_path = _ground_truth_path(scene_dir, "left")
    if gt_path is None:
        names = " or ".join(GT_NAMES["left"])
        raise FileNotFoundError(f"{scene_dir}: no left ground truth ({names})")
    disp_left = read_disparity(gt_path)
    disp1 = _ground_truth_path(scene_dir, "right")
    disp_right = None if disp1 is None else read_disparity(disp1)
    mask_path = scene_dir / "mask0nocc.png"
    mask = read_image(mask_path) if mask_path.is_file() else None
    if mask is not None and mask.ndim != 2:
        raise ValueError(f"{mask_path}: expected a grey mask, got shape {mask.shape}")
    check_sample_shapes(scene_dir, left, right, disp_left, disp_right, mask)
    calib_path = scene_dir / "calib.txt"
    calib = read_calib(calib_path) if calib_path.is_file() else None
    meta = {"dataset": "middlebury2014", "calib": calib, "scene_dir": str(scene_dir)}
    return StereoSample(left, right, disp_left, disp_right, scene_dir.name, meta, mask)


def _ground_truth_path(scene_dir: Path, view: str) -> Path | None:
    """The ground-truth file of ``view`` in ``scene_dir`` (MiddEval3 name first), or None."""
    for name in GT_NAMES[view]:
        if (scene_dir / name).is_file():
            return scene_dir / name
    return None


def _complete_calib(calib: Mapping[str, object], shape: tuple[int, int], disp: np.ndarray) -> dict:
    if not isinstance(calib, Mapping):
        raise TypeError(f"calib: expected a dict, got {type(calib).__name__}")
    missing = [k for k in REQUIRED_CALIB_KEYS if k not in calib]
    if missing:
        raise ValueError(f"calib: missing keys {missing}; required: {list(REQUIRED_CALIB_KEYS)}")
    out = dict(calib)
    h, w = shape
    for key, value in (("width", w), ("height", h)):
        if key in out and int(out[key]) != value:  # type: ignore[call-overload]
            raise ValueError(f"calib[{key!r}]: expected {value} (the image size), got {out[key]}")
        out[key] = value
    out.setdefault("isint", 0)  # MiddEval3's runeval reads it; without it evaldisp's arguments shift
    if "vmin" not in out or "vmax" not in out:
        finite = disp[np.isfinite(disp)]
        if "vmin" not in out:
            out["vmin"] = math.floor(float(finite.min())) if finite.size else 0
        if "vmax" not in out:
            out["vmax"] = math.ceil(float(finite.max())) if finite.size else 0
    return out


def write_middlebury(
    out_dir: str | os.PathLike[str],
    *,
    left: np.ndarray,
    right: np.ndarray,
    disp_left: np.ndarray,
    disp_right: np.ndarray | None,
    mask_left: np.ndarray,
    calib: Mapping[str, object],
    fsync: bool = True,
    right_exposure: np.ndarray | None = None,
    right_lighting: np.ndarray | None = None,
    highlight_left: np.ndarray | None = None,
    highlight_right: np.ndarray | None = None,
    sky_left: np.ndarray | None = None,
    layout: str = "middeval3",
    image_deflate: str | None = None,
) -> list[Path]:
    """Write one stereo pair as a MiddEval3 / Middlebury 2014 scene folder.

    The folder is what the MiddEval3 SDK (``runeval``, ``evaldisp``, ``computemask``) and
    RAFT-Stereo's Middlebury loader read as they are (see ``docs/formats.md``).

    Everything is validated and encoded before the first byte is written, and every file is
    written atomically, so an error leaves ``out_dir`` as it was.

    Parameters
    ----------
    out_dir : str or path-like
        Scene folder; created (with parents) if missing; existing files are replaced.
    left, right : (H, W, 3) or (H, W) uint8 array
        Images, RGB order.
    disp_left : (H, W) float array
        Left ground truth in pixels, ``>= 0``; ``inf`` (or NaN, written as ``inf``) exactly where
        ``mask_left == 0``.
    disp_right : (H, W) float array or None
        Right ground truth (``inf`` = none); ``disp1GT.pfm`` (``disp1.pfm``) is skipped when None.
    mask_left : (H, W) uint8 array
        Codes 255 (visible in both views), 128 (occluded in the right view), 0 (no ground truth).
    calib : dict
        ``cam0``, ``cam1`` (3x3), ``doffs``, ``baseline`` (mm), ``ndisp``, plus any other keys
        (``dyavg``, ...). ``width``/``height`` are filled from the images (and must match if
        given); ``isint`` defaults to 0 (float disparities); ``vmin``/``vmax`` default to the floor/ceil of the finite ``disp_left`` range.
    fsync : bool, default True
        ``fsync`` each file before renaming it into place.
    right_exposure, right_lighting : uint8 array like ``right``, optional
        ``im1E.png`` (the right view at another exposure) and ``im1L.png`` (under other
        lighting); each absent one is a hard link to ``im1.png`` (the same bytes, stored once;
        a copy where the file system has no hard links: :func:`write_all_atomic`).
    highlight_left, highlight_right : (H, W) uint8 array, optional
        Specular-highlight masks (255 highlight, 0 not), written as ``mask0spec.png`` and
        ``mask1spec.png`` (both or neither).
    sky_left : (H, W) uint8 array, optional
        Where the left view sees a sky at infinity (255; disparity 0 there), written as
        ``mask0sky.png``.
    layout : {"middeval3", "2014"}
        The ground truth's file names (:data:`GT_FILES`): MiddEval3's ``disp0GT.pfm``,
        ``disp1GT.pfm``, or the 2014 scene archives' ``disp0.pfm``, ``disp1.pfm``. Every other
        file, and every byte, is the same.
    image_deflate : {"isal", "libdeflate", "zlib", "stored"}, optional
        The deflate of the images' PNGs (``im0``, ``im1``, ``im1E``, ``im1L``;
        :func:`~matcher.io.png.encode_png`); default :func:`~matcher.io.png.deflate_for` each.
        ``"stored"``: no compression (~1.5x larger, several times faster, bytes fixed by the
        pixels). The masks keep theirs.

    Returns
    -------
    list of pathlib.Path
        The files written, in the order ``im0.png, im1.png, im1E.png, im1L.png, disp0GT.pfm,
        [disp1GT.pfm,] mask0nocc.png, [mask0spec.png, mask1spec.png,] [mask0sky.png,]
        calib.txt`` (``disp0.pfm``,
        ``disp1.pfm`` with ``layout="2014"``).

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> from matcher.io import load_middlebury_2014
    >>> img = np.zeros((2, 3, 3), np.uint8)
    >>> d = np.array([[1.0, 2.0, np.inf], [1.0, 2.0, 2.5]], np.float32)
    >>> mask = np.where(np.isfinite(d), 255, 0).astype(np.uint8)
    >>> cal = {"cam0": np.eye(3), "cam1": np.eye(3), "doffs": 0, "baseline": 100, "ndisp": 8}
    >>> with tempfile.TemporaryDirectory() as out:
    ...     files = write_middlebury(out, left=img, right=img, disp_left=d, disp_right=None,
    ...                              mask_left=mask, calib=cal)
    ...     s = load_middlebury_2014(out)
    >>> [f.name for f in files]
    ['im0.png', 'im1.png', 'im1E.png', 'im1L.png', 'disp0GT.pfm', 'mask0nocc.png', 'calib.txt']
    >>> s.disp_left[0].tolist(), s.meta["calib"]["vmax"]
    ([1.0, 2.0, inf], 3)
    >>> with tempfile.TemporaryDirectory() as out:
    ...     files = write_middlebury(out, left=img, right=img, disp_left=d, disp_right=d,
    ...                              mask_left=mask, calib=cal, layout="2014")
    >>> [f.name for f in files if f.suffix == ".pfm"]
    ['disp0.pfm', 'disp1.pfm']
    """
    gt_left, gt_right = GT_FILES[check_choice(layout, "layout", GT_FILES)]
    if image_deflate is not None:
        check_deflate(image_deflate, "image_deflate")
    left, right = check_stereo_images(left, right)
    shape = left.shape[:2]
    mask_left = check_occlusion_mask(mask_left, "mask_left", shape=shape)
    disp0 = check_ground_truth(disp_left, "disp_left", shape=shape, mask=mask_left)
    disp1 = None if disp_right is None else check_ground_truth(disp_right, "disp_right", shape=shape)
    full_calib = _complete_calib(calib, shape, disp0)
    for name, image in (("right_exposure", right_exposure), ("right_lighting", right_lighting)):
        if image is not None:
            if getattr(image, "shape", None) != right.shape:
                raise ValueError(f"{name}: expected the shape of the right image {right.shape}, "
                                 f"got {getattr(image, 'shape', type(image).__name__)}")
            check_stereo_images(right, image)  # uint8
    if (highlight_left is None) != (highlight_right is None):
        raise ValueError("highlight_left and highlight_right: expected both or neither, got one")
    highlights = [] if highlight_left is None else [
        check_occlusion_mask(m, name, shape=shape)
        for name, m in (("highlight_left", highlight_left), ("highlight_right", highlight_right))]
    sky = None if sky_left is None else check_occlusion_mask(sky_left, "sky_left", shape=shape)

    out = Path(out_dir)
    im1 = encode_png(right, deflate=image_deflate)
    files: dict[Path, bytes] = {
        out / "im0.png": encode_png(left, deflate=image_deflate),
        out / "im1.png": im1,
        # a variant not rendered: im1 itself (the very object: write_all_atomic links it)
        out / "im1E.png": im1 if right_exposure is None else encode_png(right_exposure,
                                                                        deflate=image_deflate),
        out / "im1L.png": im1 if right_lighting is None else encode_png(right_lighting,
                                                                        deflate=image_deflate),
        out / gt_left: encode_pfm(disp0),
    }
    if disp1 is not None:
        files[out / gt_right] = encode_pfm(disp1)
    files[out / "mask0nocc.png"] = encode_png(mask_left)
    for name, m in zip(("mask0spec.png", "mask1spec.png"), highlights):
        files[out / name] = encode_png(m)
    if sky is not None:
        files[out / "mask0sky.png"] = encode_png(sky)
    files[out / "calib.txt"] = format_calib(full_calib).encode("ascii")
    out.mkdir(parents=True, exist_ok=True)
    return write_all_atomic(files, fsync=fsync)
