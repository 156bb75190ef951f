"""The interface every output layout implements: :class:`Layout` and what it can hold
(:class:`Capacity`).

A layout answers five questions, and nothing outside :mod:`synth.formats` asks a format's name:

- **where** a sample's files go: its folder of stereoforge's own files (``scene.json``,
  ``sample.json``: :meth:`Layout.sample_dir`), the folder the tools read (:attr:`Layout.tools_root`),
  and which of the files it writes sit outside the sample folder (:attr:`Layout.placed`);
- **writing** a rendered pair (:meth:`Layout.write_files`) and the files a whole dataset gets
  (:meth:`Layout.finish_files`: scene lists, list files);
- **reading** a sample back as one :class:`matcher.io.StereoSample` (:meth:`Layout.read`; a tree
  of the layout made elsewhere: :meth:`Layout.discover`, :meth:`Layout.read_key`);
- **what it can hold** (:attr:`Layout.capacity`), checked before anything is rendered
  (:meth:`Layout.check_rig`, :meth:`Layout.check_config`);
- **which trees are its own** (:meth:`Layout.recognises`; :meth:`Layout.detect` asks every
  layout, the one place that guesses a folder's format) and which samples a SPEC such as
  ``eth3d:DIR`` names (:meth:`Layout.open_spec`: :class:`SceneRef` each, read by
  :meth:`SceneRef.read`).

Read-only layouts (:attr:`Layout.writable` false: Middlebury 2005/2006, scikit-image's
*Motorcycle*, ETH3D, DrivingStereo) answer the reading questions only.

The folder a pair is written into (``dest``) stands for the sample folder: a file at
``dest/<name>`` ends in the sample folder, a file at ``dest/<p>/...`` with ``p`` in
:attr:`Layout.placed` at ``<dataset>/<p>/...`` (:mod:`synth.dataset.storage.commit` moves them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from matcher.io import StereoSample, write_all_atomic
from stereoforge.errors import DatasetError, ParameterError
from synth.formats.reading import (calib_from_rig, checked_sample,
                                   damage_as_format_error, fill_occlusion, rig_record)

__all__ = ["JPEG_QUALITY", "Capacity", "Layout", "SceneRef", "ndisp_for", "spec_error",
           "swap_folder", "without_sky", "write_tree"]

#: Quality of the JPEG images of the layouts that store JPEG (no chroma subsampling).
JPEG_QUALITY = 95


@dataclass(frozen=True)
class Capacity:
    """What a layout can hold.

    Attributes
    ----------
    right_disparity : bool
        The right view's ground truth is written.
    flow : bool
        The exact 2-D flow of a rig with camera errors (``flow0.flo``) is written.
    extra_ground_truth : bool
        The optional ground truth of :mod:`synth.formats.extras` (depth, normals, ...) has a
        place beside the files.
    disp_quantum : float or None
        Step of the stored disparity in pixels (KITTI 1/256, CREStereo 1/32, FSD 1/1000);
        ``None``: float32, exact.
    disp_max : float or None
        Largest disparity the files can hold (pixels); ``None``: unbounded.
    lossless : bool
        Images are stored without loss (PNG); ``False``: JPEG (:func:`matcher.io.encode_jpeg`).
    sample_folders : bool
        Samples can be read one by one from folders (``False``: tar shards).
    """

    right_disparity: bool
    flow: bool = False
    extra_ground_truth: bool = False
    disp_quantum: float | None = None
    disp_max: float | None = None
    lossless: bool = True
    sample_folders: bool = True


@dataclass(frozen=True)
class SceneRef:
    """One sample of a tree named by a SPEC (``eth3d:DIR``, ``middlebury:DIR:3``, ...): what
    ``validate --real``, ``train`` and the benchmarks read, through its layout.

    Attributes
    ----------
    layout : str
        The name of the layout reading it (:func:`synth.formats.get_layout`).
    root : str
        The folder ``key`` is relative to.
    key : str
        The sample in the tree (one of :meth:`Layout.discover`; ``"."``: ``root`` itself).
    scene : str
        Its name in results: ``middlebury:third/Moebius``, ``eth3d:delivery_area_1s``.
    name : str
        Its short name: ``Moebius``, ``delivery_area_1s``, ``000007``.
    kind : str
        What kind of scene it is, as results and records name it (:attr:`Layout.kind`).
    divisor : float or None
        Middlebury 2005/2006 codes per pixel.
    note : str or None
        Worth telling the user (where an inferred divisor came from).
    """

    layout: str
    root: str
    key: str
    scene: str
    name: str
    kind: str
    divisor: float | None = None
    note: str | None = None

    def read(self) -> StereoSample:
        """The sample, as its layout reads it (:meth:`Layout.read_ref`), confined to its root
        (:func:`matcher.io.files.confined`) and its arrays checked (:func:`checked_sample`)."""
        from matcher.io.files import confined
        from synth.formats import get_layout

        with confined(self.root), damage_as_format_error(self.scene):
            return checked_sample(get_layout(self.layout).read_ref(self), self.scene)


def spec_error(spec: str, why: str) -> ParameterError:
    """The error of a SPEC that names no sample: ``'SPEC': why``."""
    return ParameterError(f"{spec!r}: {why}")


class Layout:
    """One output layout (subclassed once per layout, registered in :mod:`synth.formats`).

    Attributes
    ----------
    name : str
        The ``--format`` name.
    title : str
        What it is, for messages and docs.
    capacity : Capacity
    tools_root : str
        The dataset's folder that the tools read: it holds the files of samples only (and those
        of :meth:`finish_files`).
    sample_parent : str
        The folder holding the sample folders ``NNNNNN/`` (``scene.json``, ``sample.json``).
    placed : tuple of str
        First parts of the paths under ``dest`` (:meth:`write_files`) that are paths in the
        dataset rather than in the sample folder.
    """

    name: str = ""
    title: str = ""
    capacity: Capacity = Capacity(right_disparity=True)
    tools_root: str = ""
    sample_parent: str = ""
    placed: tuple[str, ...] = ()
    #: Whether stereoforge writes it (``--format``); read-only layouts only read trees.
    writable: bool = True
    #: The ``--real`` SPEC form that names its trees (``eth3d:DIR``); None: no SPEC of its own.
    spec_form: str | None = None
    #: The metric the field reports on its real scenes (:data:`synth.formats.METRICS`).
    metric: str = "bad2"

    @property
    def kind(self) -> str:
        """What kind of scene a sample of it is, as results and records name it."""
        return self.name

    @property
    def scheme(self) -> str | None:
        """The SPEC's prefix (``eth3d`` of ``eth3d:DIR``), or None."""
        return None if self.spec_form is None else self.spec_form.partition(":")[0]

    @property
    def writes_as(self) -> str:
        """The layout whose files a sample of this one is written as before it is stored
        (``webdataset``: ``middlebury`` folders, packed into shards); usually itself."""
        return self.name

    # ------------------------------------------------------------------ where
    def sample_dir(self, root: Any, index: int) -> Any:
        """The folder of sample ``index`` (``root`` a :class:`~pathlib.Path` or an fsspec path)."""
        return root / self.sample_parent / f"{int(index):06d}"

    def dataset_path(self, rel: str, index: int) -> str:
        """The path in the dataset of a file written at ``dest/rel`` for sample ``index``."""
        if rel.split("/", 1)[0] in self.placed:
            return rel
        return f"{self.sample_parent}/{int(index):06d}/{rel}"

    # ------------------------------------------------------------------ checks
    def check_rig(self, rig: Any, *, source: str) -> None:
        """Refuse a rig whose disparities the files cannot hold, before anything is rendered.

        A rendered point lies between the rig's ``near`` and ``far`` planes, so its disparity
        lies in ``[fx B / far, fx B / near]``. Above :attr:`Capacity.disp_max`, or at most half a
        quantum (it would round to code 0, "no ground truth", as the encoders refuse), is
        refused: never clipped in silence.
        """
        cap = self.capacity
        if cap.disp_max is None and cap.disp_quantum is None:
            return
        fb = float(rig.fx) * float(rig.baseline)
        largest, smallest = fb / float(rig.near), fb / float(rig.far)
        if cap.disp_max is not None and largest > cap.disp_max:
            raise ParameterError(
                f"{source}: --format {self.name} holds disparities up to {cap.disp_max:g} px, but "
                f"this rig makes up to fx*baseline/near = {fb:g}/{float(rig.near):g} = "
                f"{largest:.4g} px; set [rig] near >= {fb / cap.disp_max:.4g} (m), a smaller "
                "baseline or focal length, or a layout with float disparities (--format "
                "sceneflow or middlebury)")
        if cap.disp_quantum is not None and smallest <= cap.disp_quantum / 2:
            raise ParameterError(
                f"{source}: --format {self.name} stores disparities in steps of "
                f"{cap.disp_quantum:g} px, but this rig makes disparities down to "
                f"fx*baseline/far = {smallest:.4g} px, which would read back as 'no ground "
                f"truth'; set [rig] far <= {2 * fb / cap.disp_quantum:.6g} (m), or use a layout "
                "with float disparities (--format sceneflow or middlebury)")

    def check_config(self, *, flow: bool, ground_truth: tuple[str, ...], source: str,
                     image_deflate: str | None = None) -> None:
        """Refuse what the layout has no place for: a rig's flow, the optional ground truth, a
        deflate for images it stores as JPEG."""
        if image_deflate is not None and not self.capacity.lossless:
            raise ParameterError(f"{source}: image_deflate = {image_deflate!r} has no PNG image to "
                                 f"encode in the {self.title} layout, which stores its images as "
                                 "JPEG; drop image_deflate, or use --format middlebury, kitti, "
                                 "sceneflow or webdataset")
        if flow and not self.capacity.flow:
            raise DatasetError(f"{source}: the [rig] camera errors give each sample a flow0.flo, "
                               f"which the {self.title} layout cannot hold; use --format "
                               "middlebury (or webdataset)")
        if ground_truth and not self.capacity.extra_ground_truth:
            raise ParameterError(f"{source}: ground_truth = {list(ground_truth)} has no place in "
                                 f"the {self.title} layout; use --format middlebury or "
                                 "webdataset, or drop ground_truth")

    def count_note(self, count: int) -> str | None:
        """What a dataset of ``count`` samples lacks in this layout, in one line for the user
        (``stereoforge dataset`` prints it); None: nothing."""
        return None

    # ------------------------------------------------------------------ writing
    def write_files(self, pair: Any, dest: Path, *, scene: Any, index: int, clean: Any,
                    fsync: bool, image_deflate: str | None = None) -> list[Path]:
        """Write the layout's files of ``pair`` under ``dest`` (see the module docstring);
        ``clean`` is the pair before the sensor and photometric models (or ``pair``);
        ``image_deflate`` the deflate of the images' PNGs (:func:`matcher.io.encode_png`;
        ``None``: its default; a layout whose images are JPEG refuses any other in
        :meth:`check_config`)."""
        raise NotImplementedError

    def finish_files(self, names: list[str]) -> dict[str, bytes]:
        """The files of the whole dataset (path in the dataset -> bytes: scene lists, list
        files), from the complete samples' folder names; written after every run, checked by
        ``dataset --verify``. Default: none."""
        return {}

    # ------------------------------------------------------------------ reading
    def key(self, index: int) -> str:
        """The key of sample ``index`` of a stereoforge dataset, for :meth:`read_key`."""
        raise NotImplementedError

    def read_key(self, root: Path, key: str) -> StereoSample:
        """One sample of a tree of this layout (``root``: the folder a training codebase is
        given; ``key``: one of :meth:`discover`)."""
        raise NotImplementedError

    def discover(self, root: Path) -> list[str]:
        """The keys of every sample with ground truth in a tree of this layout, sorted."""
        raise NotImplementedError

    def recognises(self, root: Path) -> bool:
        """Whether ``root`` is a tree of this layout (what :meth:`detect` asks); default: no."""
        return False

    @staticmethod
    def detect(folder: Path, *, among: Sequence[str] | None = None) -> Layout | None:
        """The first layout (registry order; only those named in ``among``) that recognises
        ``folder`` (:meth:`recognises`), or None: the one place a folder's format is guessed."""
        from synth.formats import get_layout, layouts

        candidates = layouts() if among is None else [get_layout(n) for n in among]
        folder = Path(folder)
        if not folder.is_dir():
            return None
        return next((layout for layout in candidates if layout.recognises(folder)), None)

    def open_spec(self, spec: str, rest: str) -> list[SceneRef]:
        """The samples ``spec`` (``<scheme>:<rest>``) names: by default ``rest`` is the root of
        a tree of this layout, and every sample :meth:`discover` finds is one.

        Raises
        ------
        ParameterError
            ``rest`` is not a folder, or holds no sample with ground truth.
        """
        root = Path(rest)
        if not root.is_dir():
            raise spec_error(spec, f"{root} is not a folder; give the root of a tree in the "
                                   f"{self.title} layout (see docs/formats.md)")
        keys = self.discover(root)
        if not keys:
            raise spec_error(spec, f"no sample with ground truth in {root} in the {self.title} "
                                   "layout (see docs/formats.md for its tree)")
        return [self.ref(root, key, scene=f"{self.scheme}:{root.name}/{key}") for key in keys]

    def ref(self, root: Path, key: str, *, scene: str, name: str | None = None,
            divisor: float | None = None, note: str | None = None) -> SceneRef:
        """A :class:`SceneRef` of this layout (``name``: the key's last part by default)."""
        return SceneRef(self.name, str(root), key, scene, name or Path(key).name or Path(root).name,
                        self.kind, divisor, note)

    def read_ref(self, ref: SceneRef) -> StereoSample:
        """The sample ``ref`` names (:meth:`read_key` of its root and key)."""
        return self.read_key(Path(ref.root), ref.key)

    def read(self, root: Path, index: int, *, extras: bool = False) -> StereoSample:
        """Sample ``index`` of a stereoforge dataset in ``root``: the layout's files, the
        occlusion mask filled where the layout has none (:func:`fill_occlusion`), ``calib``
        from the sample's ``scene.json``, ``meta["ndisp"]`` from its ``calib.txt`` where it has
        one and, with ``extras`` where the layout holds it, the optional ground truth
        (:func:`synth.formats.extras.read_ground_truth`)."""
        from matcher.io import read_calib
        from matcher.io.files import confined
        from synth._util.json_records import read_json_object
        from synth.formats.extras import read_ground_truth

        folder = self.sample_dir(Path(root), index)
        with confined(root):
            sample = checked_sample(self.read_key(Path(root), self.key(index)),
                                    f"{root}: sample {int(index)}")
            scene = read_json_object(folder / "scene.json", what="scene record",
                                     keys={"rig": dict}, fix="render the sample again")
            rig = rig_record(scene["rig"], folder / "scene.json")
            more = read_ground_truth(folder) if extras and self.capacity.extra_ground_truth else {}
            meta = {**sample.meta}
            if (folder / "calib.txt").is_file():  # the search range the sample was written with
                meta["ndisp"] = int(read_calib(folder / "calib.txt")["ndisp"])
        mask, how = fill_occlusion(sample)
        meta["occlusion"] = how
        return StereoSample(sample.left, sample.right, sample.disp_left, sample.disp_right,
                            f"{int(index):06d}", meta, mask,
                            calib=calib_from_rig(rig), flow_left=sample.flow_left,
                            regions=sample.regions, extras=more)

    def __repr__(self) -> str:
        return f"<layout {self.name}: {self.title}>"


def write_tree(dest: Path, files: dict[str, bytes], *, fsync: bool) -> list[Path]:
    """Write already-encoded ``files`` (path under ``dest`` -> bytes), each atomically, making
    their folders; return their paths in order."""
    paths = {dest / rel: data for rel, data in files.items()}
    for path in paths:
        path.parent.mkdir(parents=True, exist_ok=True)
    return write_all_atomic(paths, fsync=fsync)


def swap_folder(path: str, old: str, new: str) -> str:
    """``path`` (``/``-separated) with its one folder or file named ``old`` renamed ``new``:
    how the training codebases find a sample's other files, without touching other names.

    Examples
    --------
    >>> swap_folder("frames_cleanpass/TRAIN/A/0000/left/0001.png", "left", "right")
    'frames_cleanpass/TRAIN/A/0000/right/0001.png'
    """
    parts = path.split("/")
    if parts.count(old) != 1:
        raise ValueError(f"{path}: expected one folder named {old!r}")
    parts[parts.index(old)] = new
    return "/".join(parts)


def ndisp_for(disp: np.ndarray) -> int:
    """A search bound above the largest finite disparity: ``16 * ceil((ceil(max) + 1) / 16)``."""
    finite = disp[np.isfinite(disp)]
    vmax = math.ceil(float(finite.max())) if finite.size else 0
    return 16 * math.ceil((vmax + 1) / 16)


def without_sky(pair: Any) -> Any:
    """``pair`` with its sky (disparity 0: :attr:`synth.pair.StereoPair.sky_left`) as no ground
    truth: ``inf`` in both disparities, 0 in the left mask. For the layouts whose files cannot
    hold a disparity of 0 (KITTI, CREStereo and FSD code 0 as "none"); a pair without a sky is
    returned as it is."""
    import dataclasses

    sky = getattr(pair, "sky_left", None)
    if sky is None:
        return pair
    # object disparities are fx * b / Z > 0 (Z <= far): 0 is the sky's alone, in either view
    disp_left = np.where(pair.disp_left == 0, np.float32(np.inf), pair.disp_left)
    disp_right = np.where(pair.disp_right == 0, np.float32(np.inf), pair.disp_right)
    mask = np.where(sky > 0, np.uint8(0), pair.mask_left)
    return dataclasses.replace(pair, disp_left=disp_left, disp_right=disp_right, mask_left=mask)
