"""The pairs of a validation: one folder per axis x value x seed, rendered once, verified on reuse.

A pair folder ``pairs/<axis>/<value>_s<seed>/`` is a Middlebury 2014 scene folder
(:func:`synth.write.export.write_pair`: ``im0.png``, ``im1.png``, ``disp0GT.pfm``,
``mask0nocc.png``, ``calib.txt``, ``scene.json``) plus the region masks ``mask_<region>.png``
(uint8, 255 = in the region; :func:`matcher.regions.region_masks` of the exact ground truth and the
noise-free left image), ``sample.json`` (axis, value, seed, the seed's base scene,
``max_disparity``, drawn parameters, region sizes and the fingerprint of everything that determines
the pair) and, written last, ``files.json`` (size and SHA-256 of every file). The folder is built
under a temporary name and renamed (:func:`commit_pair_folder`, which the real scenes of
:mod:`synth.validate.real` share), so it exists only whole; a rerun reuses it when its fingerprint
matches and every checksum verifies (:func:`verify_pair_folder`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

__all__ = ["PairSpec", "pair_fingerprint", "render_sample", "render_pair_folder",
           "commit_pair_folder", "record_digest", "folder_digest", "verify_pair_folder", "read_pair_folder",
           "max_disparity_for"]

RECORD = "files.json"
_VERSION = 2  # 2: each seed its own base scene (synth.validate.family)


@dataclass(frozen=True)
class PairSpec:
    """One pair of the plan: the axis, its value, the seed (sample index of the config)."""

    axis: str
    value: Any
    seed: int
    config: dict

    @property
    def folder(self) -> str:
        return f"pairs/{self.axis}/{self.value:g}_s{self.seed}"

    @property
    def scene(self) -> str:
        """The base scene of the seed (:func:`synth.validate.family.member_name`)."""
        from synth.validate.family import member_name

        return member_name(self.seed)

    @property
    def fingerprint(self) -> str:
        return pair_fingerprint(self)


def _canon(obj: Any) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))


def pair_fingerprint(spec: PairSpec) -> str:
    """SHA-256 of what determines the pair: config, axis, value, seed and this layout's version."""
    from synth.validate.axes import get_axis

    axis = get_axis(spec.axis)
    hook = None if axis.scene is None else f"{axis.scene.__module__}.{axis.scene.__qualname__}"
    text = _canon({"config": spec.config, "axis": spec.axis, "value": spec.value,
                   "seed": spec.seed, "scene_hook": hook, "version": _VERSION})
    return hashlib.sha256(text.encode()).hexdigest()


def max_disparity_for(gt: np.ndarray, width: int) -> int:
    """The search range of a pair: a multiple of 16 above its largest ground-truth disparity
    (``16 * ceil((floor(max) + 2) / 16)``, at least 16), below the width."""
    finite = gt[np.isfinite(gt)]
    top = float(finite.max()) if finite.size else 0.0
    return int(min(16 * math.ceil((math.floor(top) + 2) / 16), width - 1))


def _files_of(folder: Path) -> list[tuple[str, Path]]:
    return [(p.name, p) for p in sorted(folder.iterdir()) if p.is_file() and p.name != RECORD]


def render_sample(config_dict: dict, seed: int, renderer: Any, *, scene_hook: Any = None,
                  value: Any = None) -> tuple[Any, Any, Any, Any]:
    """Sample ``seed`` of a dataset config (dict form), with ``scene_hook(scene, rig, value)``
    applied to its drawn scene: ``(pair, images, scene, draw)``, ``pair`` the exact render,
    ``images`` after the config's photometric models (as ``stereoforge dataset`` draws them)."""
    from synth.dataset.config.parse import config_from_dict
    from synth.dataset.config.sampling import STREAM_PHOTOMETRIC, draw_sample, stream
    from synth.dataset.sample import render_draw
    from synth.appearance.photometric import apply_photometric
    from synth.appearance.texture_control import match_edge_density

    config = config_from_dict(config_dict, source="sweep")
    draw = draw_sample(config, seed)
    scene = draw.scene
    if scene_hook is not None:
        scene = scene_hook(scene, draw.rig, value)
    if draw.edge_density is not None:
        scene = match_edge_density(scene, draw.rig, draw.edge_density, renderer=renderer).scene
    pair = render_draw(config, draw, scene, renderer)
    # an exposure or lighting change between the cameras: the matcher's right view is the
    # variant (Middlebury's im1E / im1L), under the same sensor model
    right = (pair.right_lighting if pair.right_lighting is not None
             else pair.right_exposure if pair.right_exposure is not None else pair.right)
    images = apply_photometric(pair.left, right, draw.photometric,
                               rng=stream(draw.seed, STREAM_PHOTOMETRIC))
    return pair, images, scene, draw


def commit_pair_folder(out: Path, folder: str, write: Callable[[Path], None],
                       masks: dict[str, np.ndarray], record: dict, *, index: int = 0) -> dict:
    """Write pair folder ``out/folder`` atomically and return ``record``.

    ``write(tmp)`` writes the layout's files into the temporary folder; then come the region
    masks ``mask_<region>.png``, ``sample.json`` (``record`` with ``region_pixels``) and, last,
    ``files.json`` (completion record ``index``). The folder is renamed into place whole.
    """
    from matcher.io import atomic_write_bytes, encode_png
    from matcher.regions import REGIONS
    from synth.dataset.storage.integrity import completion_record

    final = out / folder
    tmp = final.parent / f".{final.name}.tmp-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    record = {**record, "region_pixels": {n: int(masks[n].sum()) for n in REGIONS}}
    try:
        write(tmp)
        for name in REGIONS:
            atomic_write_bytes(tmp / f"mask_{name}.png",
                               encode_png(masks[name].astype(np.uint8) * np.uint8(255)),
                               fsync=False)
        atomic_write_bytes(tmp / "sample.json",
                           (json.dumps(record, indent=1, sort_keys=True) + "\n").encode(),
                           fsync=False)
        atomic_write_bytes(tmp / RECORD, completion_record(index, _files_of(tmp)), fsync=False)
        shutil.rmtree(final, ignore_errors=True)  # a stale or damaged folder of this pair
        os.rename(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return record


def render_pair_folder(spec: PairSpec, out: Path, renderer: Any) -> dict:
    """Render ``spec`` and write its folder under ``out`` atomically; return its sample record."""
    from matcher.regions import region_masks
    from synth.write.export import write_pair
    from synth.validate.axes import get_axis
    from synth.validate.family import member_name

    axis = get_axis(spec.axis)
    pair, images, scene, draw = render_sample(spec.config, spec.seed, renderer,
                                              scene_hook=axis.scene, value=spec.value)
    masks = region_masks(pair.disp_left, pair.mask_left, pair.left)
    degraded = dataclasses.replace(pair, left=images.left, right=images.right)
    record = {"axis": spec.axis, "value": spec.value, "seed": spec.seed,
              "scene": member_name(spec.seed), "sample_seed": draw.seed,
              "fingerprint": pair_fingerprint(spec),
              "max_disparity": max_disparity_for(pair.disp_left, pair.rig.width),
              "params": dict(draw.params)}
    return commit_pair_folder(
        out, spec.folder, lambda tmp: write_pair(degraded, tmp, scene=scene, seed=draw.seed,
                                                 preview=False, fsync=False),
        masks, record, index=spec.seed)


def record_digest(folder: Path) -> str:
    """SHA-256 of a pair folder's ``files.json`` (the folder's digest), not verified."""
    return hashlib.sha256((folder / RECORD).read_bytes()).hexdigest()


def folder_digest(folder: Path) -> str | None:
    """SHA-256 of a pair folder's ``files.json`` when every file of the folder verifies
    against it (the same names, sizes and SHA-256); None otherwise."""
    from synth.dataset.storage.integrity import completion_record

    try:
        stored = (folder / RECORD).read_bytes()
        doc = json.loads(stored)
        listed, index = doc["files"], doc["index"]
        files = _files_of(folder)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if sorted(listed) != [n for n, _ in files] or completion_record(index, files) != stored:
        return None
    return record_digest(folder)


def verify_pair_folder(spec: Any, out: Path) -> dict | None:
    """The sample record of a finished folder whose fingerprint matches and whose every file
    verifies against ``files.json``; None otherwise (then it is made again). ``spec`` is a
    :class:`PairSpec` or a real scene (:class:`synth.validate.real.RealSpec`)."""
    folder = out / spec.folder
    try:
        record = json.loads((folder / "sample.json").read_bytes())
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("fingerprint") != spec.fingerprint:
        return None
    return record if folder_digest(folder) is not None else None


def read_pair_folder(folder: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                            dict[str, np.ndarray]]:
    """``left, right, gt, masks`` of a pair folder (RGB uint8 images, float32 GT, bool masks),
    read as the Middlebury scene folder it is (:func:`synth.formats.read_sample`).

    Raises
    ------
    DatasetError
        The folder has no region masks (``mask_all.png``): it is not a validate pair folder.
    """
    from stereoforge.errors import DatasetError
    from synth.formats import read_sample

    s = read_sample(folder)
    if s.regions is None:
        raise DatasetError(f"{folder}: no region masks (mask_all.png), so it is not a validate "
                           "pair folder; delete it and run validate again")
    return s.left, s.right, s.disp_left, s.regions
