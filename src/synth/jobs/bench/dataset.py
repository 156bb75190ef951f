"""Dataset throughput (``stereoforge bench dataset``) and the edge density check.

Three measurements, all returning table rows (print them with :func:`synth.jobs.bench.render.write_table`):

- :func:`bench_dataset`: pairs per second of the dataset job (the per-sample task of
  :func:`synth.dataset.run_dataset` on its engine: drawing, rendering, photometric models,
  statistics, writing into a temporary directory) for each configuration and worker count,
  over the whole run and at steady state (without worker start-up), and the scaling efficiency
  ``(rate_w / rate_1) / w``;
- :func:`profile_dataset`: where one worker's time goes, per stage, in milliseconds per pair
  (texture synthesis is measured on its own and is part of ``render``);
- :func:`check_edge_density`: measured against requested edge density on given presets.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from matcher.io import DEFLATE, check_deflate
from synth.dataset.config.parse import resized
from synth.dataset.config.rig_draws import config_rigs
from synth.formats import DEFAULT_FORMAT, get_layout

if TYPE_CHECKING:
    from synth.dataset.config.parse import DatasetConfig

__all__ = ["bench_dataset", "profile_dataset", "check_edge_density", "resized",
           "with_image_deflate"]


class _Stamped:
    """A dataset task that returns the worker's pid and CPU time (all its threads) when done."""

    def __init__(self, task: Any) -> None:
        self.task = task
        self.width, self.height, self.backend = task.width, task.height, task.backend
        self.preload = (type(task).__module__, *getattr(task, "preload", ()))

    def __call__(self, index: int, renderer: Any) -> dict:
        result = self.task(index, renderer)
        files = result[1] if isinstance(result, tuple) else None  # returned for the driver
        return {"pid": os.getpid(), "cpu": time.process_time(), "files": files}


def _steady_cpu_per_pair(stamps: Sequence[dict]) -> float:
    """CPU seconds per pair between each worker's first and last completion (summed)."""
    by_pid: dict[int, list[float]] = {}
    for s in stamps:
        by_pid.setdefault(s["pid"], []).append(s["cpu"])
    cpu = sum(max(v) - min(v) for v in by_pid.values())
    pairs = sum(len(v) - 1 for v in by_pid.values())
    return cpu / pairs if pairs else float("nan")


def _cpu_seconds() -> float:
    """CPU time of this process and its descendants, all threads: the live ones (the engine's
    fork server, its workers) and those reaped by this process or by a live descendant."""
    import psutil

    me = psutil.Process()
    total = 0.0
    for proc in (me, *me.children(recursive=True)):
        try:
            t = proc.cpu_times()
        except psutil.NoSuchProcess:  # exited meanwhile: counted by whoever reaps it
            continue
        total += t.user + t.system + t.children_user + t.children_system
    return total


#: Training pairs of FlyingThings3D (960 x 540): the scale the steady rate is extrapolated to.
FLYINGTHINGS3D_PAIRS = 35_454


def bench_dataset(
    *,
    configs: Sequence[str] = ("planes", "texture-sweep", "flying"),
    count: int = 40,
    workers: Sequence[int] = (1, 2),
    backend: str = "auto",
    progress: bool = False,
    size: tuple[int, int] | None = None,
    engine: str = "local",
    address: str | None = None,
    formats: Sequence[str] = (DEFAULT_FORMAT,),
    image_deflates: Sequence[str | None] = (None,),
) -> list[dict]:
    """Pairs per second of whole dataset runs, per configuration, layout and worker count.

    Parameters
    ----------
    configs : sequence of str
        Example names or TOML paths (their rig sets the size: 640 x 480 for the examples).
    count : int
        Samples per run (each run writes a fresh temporary dataset).
    workers : sequence of int
        Worker counts to compare; efficiency is relative to the first.
    backend : {"auto", "egl", "osmesa"}
    progress : bool
    size : (width, height), optional
        Render at this size instead of the configuration's (``fx`` scales with the width, so the
        horizontal field of view and the scenes' framing stay those of the configuration).
    engine : {"local", "ray"}
        ``"ray"``: a local Ray of ``workers`` CPUs on the loopback, started and shut down per
        run (its start-up is in ``seconds``, not in the steady rate); the actors return each
        sample's bytes and this process commits them, as :func:`synth.run_dataset` does on a
        cluster, so ``driver_cpu_ms_per_pair`` shows what one driver spends per pair.
    address : str, optional
        ``engine="ray"``: the Ray cluster to measure (``HOST:PORT``), joined once for every run
        instead of a local Ray.
    formats : sequence of str
        Layouts to write (:mod:`synth.formats`), each run in turn for every configuration.
    image_deflates : sequence of str or None
        The configurations' ``image_deflate`` (the deflate of the images' PNGs,
        :func:`matcher.io.encode_png`), each run in turn; ``None``: the configuration's own.

    Returns
    -------
    list of dict
        ``config, size, format, image_deflate, workers, pairs, seconds, pairs_per_s`` (whole run, start-up
        included), ``steady_pairs_per_s`` (between the first and the last completion, i.e.
        without start-up), ``startup_s`` (``seconds - pairs / steady_pairs_per_s``) and
        ``pairs_per_cpu_s`` (pairs per CPU second of this process and its descendants, all
        threads: workers, the engine's fork server, the GL probe; robust to other load on the
        machine), ``steady_cpu_ms_per_pair`` (CPU time
        of the workers, all threads, per pair at steady state: what the run costs without
        start-up, whatever else loads the machine; ``1000 * cores / steady_cpu_ms_per_pair``
        bounds the steady rate of an idle machine), ``efficiency`` (steady rate over
        ``workers / workers[0]`` times the first one's), ``minutes_for_35454`` (the steady rate
        extrapolated to FlyingThings3D's 35,454 training pairs), ``driver_cpu_ms_per_pair``
        (CPU time of this process per pair at steady state: receiving and committing returned
        samples on Ray; next to nothing for local worker processes; the whole sample for one
        local worker, which runs in this process), ``engine`` and ``cold`` (True for
        the first multi-worker run of this call; see below).

    The first multi-worker run of a process also starts the engine's fork server (imports and numba
    set-up, ~1.5 s, see :mod:`synth.dataset.engine.tasks`) and probes the GL backend; later runs
    (the next configurations, or the same one listed twice) reuse both, so their ``startup_s`` is
    smaller. ``cold`` marks the first such run of this call (cold unless the process ran a
    multi-worker job before).
    """
    from synth.dataset.config.parse import load_config
    from synth.dataset.engine.tasks import check_engine

    check_engine(engine, workers=min(workers, default=1), address=address)
    loaded = [load_config(name) for name in configs]  # every error before the first run
    if size is not None:
        loaded = [resized(cfg, *size) for cfg in loaded]
    loaded = [cfg if deflate is None else with_image_deflate(cfg, deflate)
              for cfg in loaded for deflate in image_deflates]
    for name in formats:  # what a layout cannot hold, before the first run
        layout = get_layout(name)
        for cfg in loaded:
            layout.check_config(flow=any(r.errors is not None for r in config_rigs(cfg)),
                                ground_truth=tuple(cfg.ground_truth or ()), source=str(cfg.source),
                                image_deflate=cfg.image_deflate)
            for rig in config_rigs(cfg):
                layout.check_rig(rig, source=str(cfg.source))
    rows: list[dict] = []
    with contextlib.ExitStack() as cluster:
        if address is not None:  # joined once: every run below uses this connection
            from synth.dataset.engine.ray_driver import ray_connection

            cluster.enter_context(ray_connection(address))
        for cfg in loaded:
            for layout_name in formats:
                for w in workers:
                    # cold: the first multi-worker run of this call also starts the worker server
                    cold = engine == "local" and w > 1 and not any(
                        r["workers"] > 1 for r in rows)
                    rows.append(_bench_run(cfg, count, w, backend, engine, address, cold,
                                           layout_name))
                first = rows[-len(workers)]
                for row in rows[-len(workers):]:
                    row["efficiency"] = (row["steady_pairs_per_s"] / first["steady_pairs_per_s"]
                                         / (row["workers"] / workers[0]))
    return rows


def _bench_run(cfg: DatasetConfig, count: int, w: int, backend: str, engine: str,
               address: str | None, cold: bool, fmt: str = DEFAULT_FORMAT) -> dict:
    """One run of ``count`` samples of ``cfg`` on ``w`` workers: a row of :func:`bench_dataset`
    (``efficiency`` is filled in by the caller)."""
    from synth.dataset.engine.tasks import run_tasks
    from synth.dataset.run import SampleTask, commit_files

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        task = _Stamped(SampleTask(cfg, None if engine == "ray" else out, fmt, backend))
        cpu0 = _cpu_seconds()
        t0 = time.perf_counter()
        done, stamps, driver = [], [], []
        for index, stamp in run_tasks(task, range(count), workers=w, engine=engine,
                                      address=address):
            files = stamp.pop("files")
            if files is not None:  # Ray: the driver writes what the actor returned
                commit_files(out, index, files, fmt)
            done.append(time.perf_counter())
            driver.append(time.process_time())
            stamps.append(stamp)
            if len(done) == count:  # before the engine stops (Ray's processes exit
                cpu = _cpu_seconds() - cpu0  # unreaped: their CPU time is lost then)
        seconds = time.perf_counter() - t0
    steady = (count - w) / (done[-1] - done[w - 1]) if count > w else float("nan")
    driver_ms = 1e3 * (driver[-1] - driver[w - 1]) / (count - w) if count > w else float("nan")
    return {"config": cfg.name, "size": f"{cfg.rig.width}x{cfg.rig.height}", "format": fmt,
            "image_deflate": cfg.image_deflate or DEFLATE, "engine": engine, "workers": w,
            "pairs": count, "seconds": seconds,
            "pairs_per_s": count / seconds, "steady_pairs_per_s": steady,
            "startup_s": seconds - count / steady,
            # a cluster's workers are not this machine's processes
            "pairs_per_cpu_s": count / cpu if address is None else float("nan"),
            "steady_cpu_ms_per_pair": 1e3 * _steady_cpu_per_pair(stamps),
            "driver_cpu_ms_per_pair": driver_ms, "efficiency": float("nan"),
            "minutes_for_35454": FLYINGTHINGS3D_PAIRS / steady / 60.0,
            "cold": cold if engine == "local" and w > 1 else None}


def with_image_deflate(config: DatasetConfig, deflate: str) -> DatasetConfig:
    """``config`` writing its images' PNGs with ``deflate`` (a name of
    :data:`matcher.io.DEFLATES`)."""
    return dataclasses.replace(config, image_deflate=check_deflate(deflate, "image_deflate"))


def profile_dataset(config: str = "planes", *, count: int = 10, backend: str = "auto",
                    size: tuple[int, int] | None = None,
                    image_deflate: str | None = None) -> dict:
    """Milliseconds per pair in each stage of one worker (after one warm-up sample).

    Measured in a fresh child process set up like one worker of a run that gives each worker
    one core (:func:`synth.dataset.engine.tasks.configure_worker`: one OpenCV and numba thread,
    tuned malloc; llvmpipe rasterizing in the calling thread; the heap frozen after the warm-up
    sample, :func:`~synth.dataset.engine.tasks.freeze_heap`), so the CPU figures are those of
    a 2-worker run on 2 cores.

    Stages: ``draw`` (parameters and scene), ``search`` (edge density loop), ``render``
    (``render_pair``), ``photometric``, ``stats`` (Canny and GT statistics), ``write``
    (PNG/PFM encoding, scene.json, sample.json, into the worker's temporary folder: mostly
    encoding). Inside ``render`` (see :meth:`synth.render.Renderer.pass_timings`): ``meshes``
    (scene to vertex arrays, texture synthesis included), ``upload`` (GL buffers, textures and
    mipmaps), ``colour`` (the 4x multisampled colour passes of both views, their resolve and
    read-back), ``depth`` (the float depth passes); and ``texture``, the texture synthesis alone
    (measured apart). Not in ``total``: ``commit``, what the driver spends per pair on the Ray
    engine or a URL output (the completion record, reading the files back as the worker returns
    them, and :func:`~synth.dataset.storage.fs.commit_sample` into a local folder; an object store
    adds its upload time). ``size``: render at ``(W, H)`` instead; ``image_deflate``: the
    configuration's images deflated so (:func:`with_image_deflate`).

    Returns
    -------
    dict
        ``config``, ``size``, ``image_deflate``, ``pairs``, one ``<stage>_ms`` entry per stage
        (wall time), ``total_ms`` and ``outside_gl_ms`` (``total_ms`` less ``upload``,
        ``colour`` and ``depth``: the work around the GL passes), and the same in CPU time of
        the worker, all threads (``<stage>_cpu_ms``, ``total_cpu_ms``, ``outside_gl_cpu_ms``).
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                             initializer=_profiler_setup, initargs=(os.getpid(),)) as pool:
        return pool.submit(_profile, config, count, backend, size, image_deflate).result()


#: Render sub-stages (:meth:`synth.render.Renderer.pass_timings`) in the profile's columns.
_PASSES = ("meshes", "upload", "colour", "depth")


def _profiler_setup(parent: int) -> None:
    from synth.dataset.engine.tasks import configure_worker, die_with_parent

    die_with_parent(also=parent)
    configure_worker(1)


def _profile(config: str, count: int, backend: str, size: tuple[int, int] | None,
             image_deflate: str | None = None) -> dict:
    from scenes import build_meshes
    from synth.dataset.config.parse import load_config
    from synth.dataset.engine.tasks import freeze_heap, renderer_threads
    from synth.dataset.run import commit_returned, produce_sample
    from synth.dataset.config.sampling import draw_sample
    from synth.render.renderer import Renderer

    cfg = load_config(config)
    if size is not None:
        cfg = resized(cfg, *size)
    if image_deflate is not None:
        cfg = with_image_deflate(cfg, image_deflate)
    timings: dict[str, float] = {}
    passes: dict[str, float] = {}
    texture = texture_cpu = commit = 0.0
    with Renderer(cfg.rig.width, cfg.rig.height, backend=backend,
                  threads=renderer_threads(1)) as renderer, \
            tempfile.TemporaryDirectory() as tmp:
        produce_sample(cfg, count, renderer, Path(tmp) / "warm", DEFAULT_FORMAT)
        freeze_heap()  # as a worker does after its first sample
        (Path(tmp) / "out").mkdir()
        for i in range(count):
            with renderer.pass_timings(passes):
                produce_sample(cfg, i, renderer, Path(tmp) / f"{i:06d}", DEFAULT_FORMAT,
                               timings=timings)
            t0 = time.perf_counter()
            commit_returned(Path(tmp) / f"{i:06d}", Path(tmp) / "out", i, DEFAULT_FORMAT)
            commit += time.perf_counter() - t0
            scene = draw_sample(cfg, i).scene
            t0, c0 = time.perf_counter(), time.process_time()
            build_meshes(scene)
            texture += time.perf_counter() - t0
            texture_cpu += time.process_time() - c0
    row: dict = {"config": cfg.name, "size": f"{cfg.rig.width}x{cfg.rig.height}",
                 "image_deflate": cfg.image_deflate or DEFLATE, "pairs": count}
    stages = ("draw", "search", "render", "photometric", "stats", "write")
    for suffix, extra in (("", texture), ("_cpu", texture_cpu)):
        for stage in stages:
            row[f"{stage}{suffix}_ms"] = 1e3 * timings.get(stage + suffix, 0.0) / count
        for name in _PASSES:
            row[f"{name}{suffix}_ms"] = 1e3 * passes.get(name + suffix, 0.0) / count
        row[f"texture{suffix}_ms"] = 1e3 * extra / count
        row[f"total{suffix}_ms"] = sum(row[f"{stage}{suffix}_ms"] for stage in stages)
        # what the CPU spends around the GL passes (the figure a GPU does not take away)
        row[f"outside_gl{suffix}_ms"] = row[f"total{suffix}_ms"] - sum(
            row[f"{name}{suffix}_ms"] for name in _PASSES[1:])
    row["commit_ms"] = 1e3 * commit / count
    return row


def check_edge_density(
    *,
    presets: Sequence[str] = ("fronto_plane", "slanted_plane", "boxes"),
    targets: Sequence[float] = (0.02, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3),
    size: tuple[int, int] = (640, 480),
    seed: int = 0,
    contrast: float = 0.8,
    backend: str = "auto",
) -> list[dict]:
    """Requested vs measured edge density of :func:`match_edge_density` (noise textures).

    Returns
    -------
    list of dict
        ``preset, target, measured, error, frequency_px, probes, seconds`` per pair.
    """
    from scenes import get_preset
    from synth.render.renderer import Renderer
    from synth.camera.rig import StereoRig
    from synth.appearance.texture_control import match_edge_density, retexture

    rig = StereoRig.default(*size)
    rows = []
    with Renderer(*size, backend=backend) as renderer:
        for name in presets:
            base = retexture(get_preset(name, seed=seed), fx=rig.fx, kind="noise",
                             contrast=contrast)
            for target in targets:
                t0 = time.perf_counter()
                r = match_edge_density(base, rig, target, renderer=renderer)
                rows.append({"preset": name, "target": target, "measured": r.edge_density,
                             "error": r.edge_density - target, "frequency_px": r.frequency_px,
                             "probes": r.probes, "seconds": time.perf_counter() - t0})
    return rows
