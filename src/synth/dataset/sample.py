"""One sample of a dataset: drawn, rendered, degraded, measured and written; the per-sample task.

:func:`produce_sample` turns sample ``index`` of a configuration into its files in a folder
(its bytes depend only on the configuration and ``index``); :class:`SampleTask` is the picklable
job the engines (:mod:`synth.dataset.engine.tasks`) run on each worker, committing the sample
(:mod:`synth.dataset.storage.commit`) or returning its bytes to the driver.
"""

from __future__ import annotations

import dataclasses
import errno
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from matcher.io import atomic_write_bytes
from stereoforge.errors import StereoforgeError
from synth._util.json_records import json_bytes
from synth._util.ranges import finite_range
from synth.dataset.storage.commit import commit_local, dataset_files, returned_files, write_record
from synth.dataset.config.parse import DatasetConfig, config_from_dict
from synth.dataset.storage.integrity import completion_record
from synth.dataset.config.sampling import (
    STREAM_EXPOSURE_NOISE,
    STREAM_LIGHTING_NOISE,
    STREAM_PHOTOMETRIC,
    STREAM_TEXTURELESS,
    draw_sample,
    effective_frequency_px,
    sample_seed,
    stream,
)
from synth.formats import get_layout
from synth.write.export import write_pair
from synth.appearance.photometric import apply_photometric
from synth.appearance.texture_control import edge_density, match_edge_density

__all__ = ["SampleError", "SampleTask", "produce_sample", "render_draw", "teaches_nothing"]


#: OS errors that are the machine's, not a sample's: raised as they are (the command line gives
#: their fix), not as a failed sample to reproduce.
_ENVIRONMENT_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES,
                                 errno.EPERM, errno.EMFILE, errno.ENFILE, errno.EIO})


class SampleError(StereoforgeError, RuntimeError):
    """Rendering or writing one sample failed; ``index`` and ``seed`` reproduce it."""

    def __init__(self, index: int, seed: int, cause: str) -> None:
        super().__init__(f"sample {index} (seed {seed}) failed: {cause}; reproduce it alone with "
                         f"render_from_manifest(dataset_dir, {index}, out=...) or "
                         f"`stereoforge render --from-manifest DATASET_DIR {index} --out DIR`")
        self.index, self.seed, self.cause = index, seed, cause

    def __reduce__(self) -> tuple:  # picklable across processes
        return (SampleError, (self.index, self.seed, self.cause))


def _textureless(scene: Any, config: DatasetConfig, draw: Any, renderer: Any
                 ) -> tuple[Any, float]:
    """The scene with objects made constant toward ``textureless_area`` (stream 5 orders them),
    and its measured textureless fraction (:mod:`synth.appearance.textureless`)."""
    from synth.appearance.textureless import match_textureless, object_coverage

    rig = draw.rig
    coverage = object_coverage(scene, lambda s: renderer.render_view(s, rig, eye="left").color)
    return match_textureless(scene, float(draw.params["scene.textureless_area"]), coverage,
                             rig.width * rig.height, stream(draw.seed, STREAM_TEXTURELESS))


#: A frame teaches nothing when more of its pixels than this have no ground truth or see the sky
#: ...
USELESS_INVALID_FRACTION = 0.95
#: ... or its left image's mean grey level (0-255, all channels) is below this.
USELESS_MEAN_GREY = 15.0


def teaches_nothing(mask: np.ndarray, left: np.ndarray, sky: np.ndarray | None = None
                    ) -> str | None:
    """Why a frame teaches nothing (``"no ground truth"``, ``"too dark"``), or None.

    ``mask`` is the left occlusion mask (0: no ground truth), ``left`` the left image as written,
    ``sky`` the left sky mask of a scene with a sky (255: sky; its disparity 0 is ground truth,
    but a frame of nearly nothing else teaches nothing either).

    Examples
    --------
    >>> teaches_nothing(np.zeros((4, 4), np.uint8), np.full((4, 4, 3), 99, np.uint8))
    'no ground truth'
    >>> teaches_nothing(np.full((4, 4), 255, np.uint8), np.full((4, 4, 3), 9, np.uint8))
    'too dark'
    >>> teaches_nothing(np.full((4, 4), 255, np.uint8), np.full((4, 4, 3), 99, np.uint8),
    ...                 np.full((4, 4), 255, np.uint8))
    'no ground truth or sky'
    """
    if np.count_nonzero(mask == 0) > USELESS_INVALID_FRACTION * mask.size:
        return "no ground truth"
    if sky is not None and (np.count_nonzero((mask == 0) | (sky > 0))
                            > USELESS_INVALID_FRACTION * mask.size):
        return "no ground truth or sky"
    if float(np.mean(left)) < USELESS_MEAN_GREY:
        return "too dark"
    return None


def _depth_range_error(exc: BaseException) -> bool:
    from synth.render.meshes import DepthRangeError

    return isinstance(exc, DepthRangeError)


def _r(value: float | None) -> float | None:
    return None if value is None else round(float(value), 6)


# --------------------------------------------------------------------------- one sample
def render_draw(config: DatasetConfig, draw: Any, scene: Any, renderer: Any) -> Any:
    """The exact pair of a drawn sample: ``scene`` (the draw's, possibly changed after drawing)
    through the sample's rig (the config's, its distributions drawn), with the draw's ``im1E`` exposure and ``im1L`` relighting when it
    asks for them. The one place a dataset sample (and a validate pair) is rendered."""
    from synth.pair import render_pair

    lighting = None
    if draw.relight is not None:
        lighting = dataclasses.replace(scene, light=draw.relight[0], lamps=draw.relight[1])
    return render_pair(scene, draw.rig, renderer=renderer, exposure=draw.exposure,
                       lighting=lighting)


def produce_sample(config: DatasetConfig, index: int, renderer: Any, dest: Path, fmt: str, *,
             timings: dict[str, float] | None = None) -> dict:
    """Render sample ``index`` and write all its files into ``dest``; return its record.

    ``timings``, if given, accumulates the seconds spent per stage (draw, search, render,
    stats, photometric, write): wall time under ``stage`` and CPU time of the process (all
    threads, e.g. llvmpipe's) under ``stage + "_cpu"``.
    """
    clock = [time.perf_counter(), time.process_time()]

    def lap(stage: str) -> None:
        now = [time.perf_counter(), time.process_time()]
        if timings is not None:
            timings[stage] = timings.get(stage, 0.0) + now[0] - clock[0]
            timings[f"{stage}_cpu"] = timings.get(f"{stage}_cpu", 0.0) + now[1] - clock[1]
        clock[:] = now

    attempt, rejected = 0, []
    while True:  # a frame that teaches nothing is drawn again (``redraw``), deterministically
        draw = draw_sample(config, index, attempt=attempt)
        scene, search = draw.scene, None
        lap("draw")
        if draw.edge_density is not None:
            search = match_edge_density(scene, draw.rig, draw.edge_density, renderer=renderer)
            scene = search.scene
        textureless = None
        if "scene.textureless_area" in draw.params:
            scene, textureless = _textureless(scene, config, draw, renderer)
        lap("search")
        try:
            pair = render_draw(config, draw, scene, renderer)
        except ValueError as exc:
            if not (_depth_range_error(exc) and attempt < (config.redraw or 0)):
                raise
            rejected.append("depth range")
            attempt += 1
            continue
        lap("render")
        out = apply_photometric(pair.left, pair.right, draw.photometric,
                                rng=stream(draw.seed, STREAM_PHOTOMETRIC))
        useless = None if config.redraw is None else teaches_nothing(pair.mask_left, out.left,
                                                                     pair.sky_left)
        if useless is None or attempt >= config.redraw:
            break
        rejected.append(useless)
        attempt += 1
    variants = {}  # the right-view variants under the same sensor model, their own noise
    for name, noise in (("right_exposure", STREAM_EXPOSURE_NOISE),
                        ("right_lighting", STREAM_LIGHTING_NOISE)):
        if getattr(pair, name) is not None:
            variants[name] = apply_photometric(pair.left, getattr(pair, name), draw.photometric,
                                               rng=stream(draw.seed, noise)).right
    lap("photometric")
    if search is not None and np.array_equal(search.left, pair.left):
        rho = search.edge_density  # the search measured this very image: skip a second Canny
    else:
        rho = edge_density(pair.left)
    degraded = dataclasses.replace(pair, left=out.left, right=out.right, **variants)
    # one compiled pass (numpy's masked min and max took ~1.6 ms each at 960x540; the same
    # floats: minima and maxima are exact)
    disp_lo, disp_hi = finite_range(pair.disp_left)
    occluded = np.count_nonzero(pair.mask_left == 128)
    invalid = np.count_nonzero(pair.mask_left == 0)
    has_finite = disp_lo <= disp_hi
    mask_size = pair.mask_left.size
    stats = {
        "edge_density": _r(rho),
        "edge_search_probes": None if search is None else search.probes,
        "edge_search_converged": None if search is None else search.converged,
        "texture_frequency_px": _r(effective_frequency_px(scene, fx=draw.rig.fx)),
        "disp_min": _r(disp_lo) if has_finite else None,
        "disp_max": _r(disp_hi) if has_finite else None,
        # = np.mean(mask == code): the same float (an exact count over the size)
        "occluded_fraction": _r(occluded / mask_size),
        "invalid_fraction": _r(invalid / mask_size),
    }
    if textureless is not None:  # only then: other datasets keep their manifests' bytes
        stats["textureless_fraction"] = _r(textureless)
    if pair.sky_left is not None:  # the same
        stats["sky_fraction"] = _r(np.count_nonzero(pair.sky_left) / mask_size)
    if config.redraw is not None:  # the same
        stats["redraws"] = attempt
        stats["redrawn_for"] = rejected
        stats["teaches_nothing"] = useless  # None, or why the last allowed draw was kept
    lap("stats")
    record = {"index": index, "seed": draw.seed, "dir": f"{index:06d}",
              "params": dict(draw.params), "stats": stats}
    dest.mkdir(parents=True, exist_ok=True)
    write_pair(degraded, dest, scene=scene, seed=draw.seed, index=index,
               fmt=get_layout(fmt).writes_as,  # webdataset: shards packed from these folders
               preview=config.preview, fsync=False, clean=pair,
               image_deflate=config.image_deflate)
    if config.ground_truth:  # optional: rendered by an extra GT pass (synth.write.extra_ground_truth)
        from synth.formats.extras import write_ground_truth
        from synth.write.extra_ground_truth import render_ground_truth

        write_ground_truth(dest, render_ground_truth(pair, scene, config.ground_truth,
                                                     renderer=renderer), fsync=False)
    atomic_write_bytes(dest / "sample.json", json_bytes(record), fsync=False)
    lap("write")
    return record


class SampleTask:
    """Picklable per-sample job (see :mod:`synth.dataset.engine.tasks`).

    With ``out`` a local folder the worker writes and commits the sample itself and returns its
    record. With ``out=None`` it writes nothing where the driver writes: it renders into a
    temporary folder of its own machine and returns ``(record, files)``, ``files`` mapping each
    path in the dataset (the completion record included) to its bytes, for the driver to
    :func:`~synth.dataset.storage.fs.commit_sample` (Ray workers, URL outputs: no shared
    filesystem assumed).
    """

    preload = ("synth.pair",)  # imported once by the engine's fork server for every worker

    def __init__(self, config: DatasetConfig, out: Path | None, fmt: str, backend: str) -> None:
        self.config_dict = config.to_dict()
        self.source = config.source
        self.out, self.fmt, self.backend = None if out is None else Path(out), fmt, backend
        self.width, self.height = config.rig.width, config.rig.height
        self._config: DatasetConfig | None = config

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_config": None}

    @property
    def config(self) -> DatasetConfig:
        if self._config is None:
            self._config = config_from_dict(self.config_dict, source=self.source)
        return self._config

    def __call__(self, index: int, renderer: Any) -> dict | tuple[dict, dict[str, bytes]]:
        tmp = (Path(tempfile.mkdtemp(prefix=f"stereoforge-{index:06d}-")) if self.out is None
               else self.out / f".{index:06d}.tmp-{os.getpid()}")
        try:
            shutil.rmtree(tmp, ignore_errors=True)
            record = produce_sample(self.config, index, renderer, tmp, self.fmt)
            if self.out is None:
                files = returned_files(tmp, index, self.fmt)
                shutil.rmtree(tmp, ignore_errors=True)
                return record, files
            done = completion_record(index, dataset_files(tmp, index, self.fmt))
            commit_local(tmp, self.out, index, self.fmt)
            write_record(self.out, index, done)
            return record
        except BaseException as exc:
            shutil.rmtree(tmp, ignore_errors=True)
            if isinstance(exc, OSError) and exc.errno in _ENVIRONMENT_ERRNOS:
                raise  # disk full, read-only, no permission: the machine's, not the sample's
            if isinstance(exc, Exception) and not isinstance(exc, SampleError):
                seed = sample_seed(self.config.seed, index)
                raise SampleError(index, seed, f"{type(exc).__name__}: {exc}") from exc
            raise
