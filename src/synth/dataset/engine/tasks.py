"""Parallel execution of per-sample tasks, one GL renderer per worker.

A *task* is a picklable callable ``task(index, renderer) -> dict`` with attributes ``width``,
``height`` and ``backend`` (the renderer each worker opens). :func:`run_tasks` runs it over
indices and yields ``(index, result)`` as samples finish (in completion order; callers that need
order sort). Engines:

- ``"local"``: ``workers == 1`` runs in this process; more workers are a
  :class:`concurrent.futures.ProcessPoolExecutor` whose processes are forked by a
  ``forkserver`` (``spawn`` where there is none). The fork server is a fresh process that
  imports the task's modules (``type(task).__module__`` and the task's optional ``preload``
  tuple of module names) and warms numba once (:mod:`synth.dataset.engine.warm`); it never imports
  OpenGL, so no GL state is ever forked (a forked GL context is unusable), and each worker
  starts without importing numpy/scipy/trimesh/numba/OpenCV again. It is one per process
  (``multiprocessing``'s), started by the first multi-worker run and reused by the next ones;
  it inherits the environment of that moment. The GL backend is probed (in a subprocess, so
  OpenGL stays unimported here) while the workers start; each worker opens one
  :class:`Renderer` at its first task and reuses it. With more workers than cores / 2, each
  worker's llvmpipe gets ``cores // workers`` rasterizer threads (``0``, i.e. the calling
  thread, for one core per worker; an ``LP_NUM_THREADS`` in the environment wins) and OpenCV
  and numba as many threads, which avoids oversubscription (numba's OpenMP threads would
  spin) and does not change the outputs. Ray actors (``num_cpus=1``) are set up as one-core
  workers the same way (:func:`configure_worker`, :func:`renderer_threads`). Worker processes
  and Ray actors also tune glibc's ``malloc`` to reuse freed memory (see
  :func:`_tune_malloc`): ~15 % less CPU per 640 x 480 pair; after their first sample they
  freeze their heap for the garbage collector (:func:`freeze_heap`).
- ``"ray"``: ``workers`` Ray actors (one renderer each), on the cluster at ``address`` or on a
  local Ray started with ``num_cpus=workers`` (and shut down after). Needs ``pip install ray``.
  Each actor runs one task at a time; an actor that dies (its node lost) is replaced and its
  sample goes back to the queue, so no sample is lost (at most ``4 * workers`` losses per run).
  On the loopback (a local Ray, or an ``address`` on ``127.*``/``localhost``) the driver's node
  IP must stay 127.0.0.1 (see :func:`synth.dataset.engine.ray_driver.import_ray`). The driver
  side of Ray (its import, joining the cluster, the actor scheduling and retries) is
  :mod:`synth.dataset.engine.ray_driver`.

The first failing task stops the run: pending tasks are cancelled and its exception is raised.

One module on purpose: both engines run the same task protocol, and the worker start-up,
process lifetime and result order they share are easier to keep identical in one place.
"""

from __future__ import annotations

import ctypes
import gc
import itertools
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from concurrent.futures import (
    FIRST_COMPLETED,
    ProcessPoolExecutor,
    ThreadPoolExecutor,
    wait,
)
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

from stereoforge.errors import StereoforgeError
from synth.dataset.engine.ray_driver import RAY_CONNECT_TIMEOUT_S, check_ray_address

__all__ = ["ENGINES", "RAY_CONNECT_TIMEOUT_S", "Task", "WorkerLost", "check_engine",
           "check_ray_address", "configure_worker", "die_with_parent", "renderer_threads",
           "run_tasks", "ray_available", "start_worker_server"]

ENGINES = ("local", "ray")


class Task(Protocol):
    """What :func:`run_tasks` runs (see the module docstring).

    It may also have a ``preload`` attribute: a tuple of module names (free of GL) that worker
    processes need, imported once by the fork server.
    """

    width: int
    height: int
    backend: str

    def __call__(self, index: int, renderer: Any) -> dict: ...


def ray_available() -> bool:
    """Whether ``import ray`` works here."""
    try:
        import ray  # noqa: F401
    except ImportError:
        return False
    return True


# --------------------------------------------------------------------------- worker set-up
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3  # glibc's mallopt parameters


def _tune_malloc() -> None:
    """Make glibc keep freed memory in this worker's heap instead of unmapping it.

    A 640 x 480 sample allocates and frees ~100 MB of multi-megabyte numpy temporaries. With
    glibc's defaults most come from fresh ``mmap`` pages that fault in one by one: ~5000 page
    faults and 12-20 ms of kernel time per pair were measured here, about 15 % of its CPU cost
    (the tuned worker: ~250 faults). Arrays up to 32 MB then come from the heap, which keeps up
    to 512 MB of free memory. Worker processes only (they are ours; a caller's process is left
    alone); a no-op off glibc.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        return
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    for param, value in ((_M_MMAP_THRESHOLD, 32 << 20), (_M_TRIM_THRESHOLD, 512 << 20),
                         (_M_TOP_PAD, 64 << 20)):
        mallopt(param, value)


# --------------------------------------------------------------------------- process lifetime
_PR_SET_PDEATHSIG = 1  # linux/prctl.h
_WATCHDOG_SECONDS = 0.5


def _set_pdeathsig(sig: int) -> bool:
    """``prctl(PR_SET_PDEATHSIG, sig)``: whether it took effect (Linux only)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):  # pragma: no cover - not glibc/musl
        return False
    prctl.restype = ctypes.c_int
    return prctl(_PR_SET_PDEATHSIG, ctypes.c_ulong(sig), ctypes.c_ulong(0), ctypes.c_ulong(0),
                 ctypes.c_ulong(0)) == 0


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # pragma: no cover - someone else's process took the pid
        return True
    return True


def _watchdog(parent: int, also: int | None) -> None:
    while os.getppid() == parent and (also is None or _alive(also)):
        time.sleep(_WATCHDOG_SECONDS)
    os._exit(1)


def die_with_parent(*, also: int | None = None, watchdog: bool = True) -> bool:
    """Make this process end (SIGKILL) when its parent process ends, however the parent ends.

    On Linux this is ``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the kernel kills this process when
    the *thread* that forked it exits, so a process started from a short-lived thread dies
    with that thread. Where ``prctl`` is unavailable and ``watchdog`` is true, a daemon thread
    polls every 0.5 s whether the parent (``os.getppid()``) changed and exits then (a process
    that forks must not start it: forking a multi-threaded process is unsafe). If ``also``
    (a pid, e.g. the main process of a chain parent -> fork server -> worker) no longer runs,
    or the parent ended before the call, this process exits at once (status 1).

    Returns
    -------
    bool
        Whether the kernel will send the signal (``False``: the watchdog, or nothing).
    """
    parent = os.getppid()
    armed = _set_pdeathsig(signal.SIGKILL)
    if (also is not None and not _alive(also)) or os.getppid() != parent:
        os._exit(1)  # the parent (or the chain's head) ended before we could watch it
    if not armed and watchdog:
        threading.Thread(target=_watchdog, args=(parent, also), daemon=True,
                         name="die-with-parent").start()
    return armed


# --------------------------------------------------------------------------- local engine
_WORKER: dict[str, Any] = {}
_WARM_MODULE = "synth.dataset.engine.warm"
#: imported first: the server dies with its parent from the start
_GUARD_MODULE = "synth.dataset.engine.guard"


def _threads_per_worker(workers: int) -> int | None:
    cores = os.cpu_count() or 1
    return max(1, cores // workers) if workers > 1 else None


def _server_modules(modules: Sequence[str]) -> list[str]:
    """Modules the fork server imports once for every worker it forks (none of them GL)."""
    return [_GUARD_MODULE, __name__, *modules, _WARM_MODULE]


def _preload(task: Task) -> list[str]:
    return _server_modules([type(task).__module__, *getattr(task, "preload", ())])


def _forkserver_context(modules: list[str]) -> multiprocessing.context.BaseContext | None:
    if "forkserver" not in multiprocessing.get_all_start_methods():  # pragma: no cover
        return None
    ctx = multiprocessing.get_context("forkserver")
    # the server is one per process, started at its first use: later preload lists are ignored
    ctx.set_forkserver_preload(modules)
    return ctx


def _mp_context(task: Task) -> multiprocessing.context.BaseContext:
    """``forkserver`` preloading the task's modules where available, else ``spawn``."""
    return _forkserver_context(_preload(task)) or multiprocessing.get_context("spawn")


def start_worker_server(modules: Sequence[str] = ()) -> None:
    """Start the local engine's fork server now, so that its imports overlap the caller's.

    The server (see the module docstring) imports ``modules`` (names of GL-free modules the
    workers will need, e.g. ``["synth.dataset.run"]``) plus the engine's own, then waits; the
    first multi-worker :func:`run_tasks` forks its workers from it instead of starting it then.
    The command line calls this before its own heavy imports when ``--workers`` > 1: a cold
    ``stereoforge dataset`` saves about a second. A no-op where the server already runs (its
    module list is then kept) or where there is no ``forkserver``.

    Examples
    --------
    >>> start_worker_server(["synth.pair"])  # returns at once; the imports run in the server
    """
    ctx = _forkserver_context(_server_modules(list(modules)))
    if ctx is not None:
        from multiprocessing import forkserver

        forkserver.ensure_running()


def configure_worker(threads: int | None) -> None:
    """Set this process up as a worker that shares the cores with others (no GL): OpenCV and
    numba use ``threads`` threads (``None`` leaves them), glibc's malloc is tuned (see
    :func:`_tune_malloc`). The renderer's own threads are :func:`renderer_threads`'s."""
    if threads is not None:
        import cv2  # its thread pool too: workers already share the cores
        import numba

        cv2.setNumThreads(threads)
        # numba's parallel kernels (Canny): one OpenMP thread per worker; more only spin
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    _tune_malloc()


def renderer_threads(threads: int | None) -> int | None:
    """llvmpipe threads for a worker given ``threads`` cores: ``0`` (the calling thread: the
    least CPU per image) for one, else that many; ``None`` (the driver's default) when no count
    is given or ``LP_NUM_THREADS`` is set in the environment (the user's choice wins)."""
    if threads is None or "LP_NUM_THREADS" in os.environ:
        return None
    return 0 if threads == 1 else threads


def _init_worker(task: Task, threads: int | None, main_pid: int) -> None:
    """Worker set-up that needs no GL: lifetime, thread counts, malloc; the renderer opens on
    first use. The worker dies with its parent (the fork server, or the main process under
    ``spawn``), and at once if the main process ``main_pid`` already ended. Ctrl-C reaches
    the whole foreground process group; a worker ignores it and the main process decides (it
    cancels what is queued, lets each worker end its sample, and exits 130)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(also=main_pid)
    configure_worker(threads)
    _WORKER["task"], _WORKER["threads"] = task, threads


def _ready() -> None:
    """No-op task: submitting one per worker starts the processes early."""


def freeze_heap() -> None:
    """Move every object alive now out of the cyclic garbage collector's sight
    (``gc.freeze``), once per process: workers call it after each sample, and only the call
    after their first sample freezes (later ones would freeze each sample's cycles too).

    What is alive then (the modules, numba's dispatchers, the renderer, the caches: ~190,000
    objects in a dataset worker) stays alive, yet each full collection walked all of it: 64-72
    ms once in 100-150 960x540 ``flying`` samples (0.4-0.7 ms per sample), 0.9 ms after the
    freeze, which leaves a collection only what later samples allocate. Later garbage is found
    as before, and frozen objects are still freed by reference counting; only a reference
    cycle among them would stay (nearly all of them are in use until the worker ends).
    """
    if not _WORKER.get("frozen"):
        gc.freeze()
        _WORKER["frozen"] = True


def _run_in_worker(index: int, backend: str) -> tuple[int, dict]:
    renderer = _WORKER.get("renderer")
    if renderer is None:
        from synth.render.renderer import Renderer

        task = _WORKER["task"]
        # the parent resolved the backend on this machine: no second probe per worker
        renderer = _WORKER["renderer"] = Renderer(
            task.width, task.height, backend=backend, probe=False,
            threads=renderer_threads(_WORKER["threads"]))
    result = _WORKER["task"](index, renderer)
    freeze_heap()
    return index, result


class WorkerLost(StereoforgeError, RuntimeError):
    """A worker process of the local pool died (killed); an environment error."""


def _run_local(task: Task, indices: Sequence[int], workers: int) -> Iterator[tuple[int, dict]]:
    if workers == 1:
        from synth.render.renderer import Renderer

        with Renderer(task.width, task.height, backend=task.backend) as renderer:
            for index in indices:
                yield index, task(index, renderer)
        return
    from synth.render.renderer import resolve_backend

    pool = ProcessPoolExecutor(max_workers=workers, mp_context=_mp_context(task),
                               initializer=_init_worker,
                               initargs=(task, _threads_per_worker(workers), os.getpid()))
    probe = ThreadPoolExecutor(max_workers=1)
    ctrl_c = _DeferredInterrupt()
    try:
        # the probe (a subprocess; OpenGL stays unimported here) runs while the workers start
        with ctrl_c:
            backend_future = probe.submit(resolve_backend, task.backend)
            for _ in range(workers):
                pool.submit(_ready)
        backend = backend_future.result()
        queue = iter(indices)
        pending: set = set()
        while True:
            with ctrl_c:  # the futures' locks are never left held by a KeyboardInterrupt
                for index in itertools.islice(queue, _AHEAD_PER_WORKER * workers - len(pending)):
                    pending.add(pool.submit(_run_in_worker, index, backend))
                if not pending:
                    break
                done, pending = wait(pending, timeout=_POLL_SECONDS,
                                     return_when=FIRST_COMPLETED)
            ctrl_c.raise_if_pressed()
            for fut in sorted(done, key=lambda f: f.exception() is not None):
                try:
                    result = fut.result()  # raises the task's exception
                except BrokenProcessPool:
                    raise WorkerLost(
                        "a worker process died without a word (killed: out of memory and the "
                        "OOM killer, or a signal); the samples finished are kept: free some "
                        "memory or use fewer workers, and run the same command again to "
                        "resume") from None
                yield result
    finally:
        with ctrl_c:  # a second Ctrl-C while the workers end their current sample waits too
            probe.shutdown(wait=True, cancel_futures=True)
            pool.shutdown(wait=True, cancel_futures=True)
        ctrl_c.raise_if_pressed()


#: Samples queued per worker beyond the one it renders: enough that no worker waits for the
#: next index, few enough that each wait() (it locks every pending future) stays cheap.
_AHEAD_PER_WORKER = 2
#: How often a wait() with nothing finished returns to look for a Ctrl-C.
_POLL_SECONDS = 0.25


class _DeferredInterrupt:
    """Within ``with``, Ctrl-C (SIGINT) is recorded instead of raised; :meth:`raise_if_pressed`
    raises the ``KeyboardInterrupt`` afterwards, at a point where no lock is held.

    A ``KeyboardInterrupt`` raised inside :func:`concurrent.futures.wait` while it takes the
    futures' locks one by one leaves some of them held; the pool's manager thread then blocks
    on one for ever, and so does the ``shutdown`` that follows (Ctrl-C hung the run). Only in
    the main thread, and only where SIGINT raises (Python's default handler); elsewhere a no-op.
    """

    def __init__(self) -> None:
        self.pressed = False
        self._saved: Any = None

    def _record(self, _signum: int, _frame: Any) -> None:
        self.pressed = True

    def __enter__(self) -> _DeferredInterrupt:
        self._saved = None
        if (threading.current_thread() is threading.main_thread()
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler):
            self._saved = signal.signal(signal.SIGINT, self._record)
        return self

    def __exit__(self, *_exc: object) -> None:
        if self._saved is not None:
            signal.signal(signal.SIGINT, self._saved)
            self._saved = None

    def raise_if_pressed(self) -> None:
        if self.pressed:
            self.pressed = False
            raise KeyboardInterrupt


# --------------------------------------------------------------------------- ray engine
class _RayWorker:
    """Body of a Ray actor: one renderer, reused for every sample it is given."""

    def __init__(self, task: Task) -> None:
        from synth.render.renderer import Renderer

        configure_worker(1)  # num_cpus=1: one core, as a local worker of a full machine
        self.task = task
        self.renderer = Renderer(task.width, task.height, backend=task.backend,
                                 threads=renderer_threads(1))

    def ready(self) -> None:
        """Returns once ``__init__`` ran (the renderer is open)."""

    def run(self, index: int) -> tuple[int, dict]:
        result = self.task(index, self.renderer)
        freeze_heap()
        return index, result


def _run_ray(task: Task, indices: Sequence[int], workers: int,
             address: str | None) -> Iterator[tuple[int, dict]]:
    from synth.dataset.engine.ray_driver import ray_connection, ray_results

    with ray_connection(address, workers=workers) as ray:
        actor_cls = ray.remote(num_cpus=1, max_restarts=0)(_RayWorker)
        yield from ray_results(ray, actor_cls, task, indices, workers)


# --------------------------------------------------------------------------- entry point
def check_engine(engine: str, *, workers: int, address: str | None) -> None:
    """Raise ``ValueError`` on an unknown ``engine``, ``workers`` below 1, or an ``address``
    without ``engine="ray"`` (checked by :func:`run_tasks`, and by callers before any work)."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an int >= 1, got {workers!r}")
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    if address is not None and engine != "ray":
        raise ValueError(f"address={address!r} applies to engine='ray' only; drop it or pass "
                         "engine='ray'")


def run_tasks(task: Task, indices: Sequence[int], *, workers: int = 1, engine: str = "local",
              address: str | None = None) -> Iterator[tuple[int, dict]]:
    """Run ``task`` over ``indices``; yield ``(index, result)`` as each finishes.

    Parameters
    ----------
    task : Task
    indices : sequence of int
    workers : int
        Worker processes (local) or actors (ray), >= 1; at most ``len(indices)`` are started.
    engine : {"local", "ray"}
    address : str, optional
        Ray cluster address (``engine="ray"`` only); default: start a local Ray.

    Examples
    --------
    >>> class Square:
    ...     width, height, backend = 8, 8, "auto"
    ...     def __call__(self, index, renderer):
    ...         return {"square": index * index}
    >>> list(run_tasks(Square(), [], workers=2))  # nothing to do: no worker starts
    []
    >>> run_tasks(Square(), [1], engine="dask")
    Traceback (most recent call last):
    ...
    ValueError: engine must be one of local, ray, got 'dask'
    """
    check_engine(engine, workers=workers, address=address)
    indices = list(indices)
    if not indices:
        return iter(())
    workers = min(workers, len(indices))
    if engine == "ray":
        return _run_ray(task, indices, workers, address)
    return _run_local(task, indices, workers)
