"""The driver side of the Ray engine: importing Ray on the loopback, and running samples on
actors with retries (:func:`synth.dataset.engine.run_tasks` with ``engine="ray"``).

Each actor runs one task at a time; an actor that dies (its node lost) is replaced and its
sample goes back to the queue, so no sample is lost (at most ``4 * workers`` losses per run).
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Iterator, Sequence
from typing import Any

__all__ = ["RAY_LOOPBACK_ENV", "RAY_STALL_TIMEOUT_S", "import_ray", "on_loopback",
           "ray_results"]

_log = logging.getLogger(__name__)

#: Ray reads this once, as it is imported: "0" keeps a node IP of 127.0.0.1 as it is.
RAY_LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
#: Seconds without a running sample and without a worker starting before the run gives up.
RAY_STALL_TIMEOUT_S = 300.0


def on_loopback(address: str | None) -> bool:
    """Whether the driver joins (or starts) a Ray on the loopback: no address, or a loopback
    ``HOST:PORT``."""
    if address is None:
        return True
    if address == "auto" or "://" in address:
        return False
    host = address.rpartition(":")[0].strip("[]")
    return host in ("localhost", "::1") or host.startswith("127.")


def import_ray(address: str | None) -> Any:
    """``import ray``, made to keep the loopback for a loopback ``address`` (or a local Ray).

    Ray rewrites a node IP of 127.0.0.1 (``ray.init(_node_ip_address="127.0.0.1")``, and the
    host of ``address``) to the machine's interface address
    (``ray._private.services.resolve_ip_for_localhost``), unless its constant
    ``ENABLE_RAY_CLUSTER`` is false, which only ``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0`` in the
    environment *at Ray's import* gives (``ray/_private/ray_constants.py``; on Linux it only
    changes that rewrite and whether ``ray start`` adds a worker node *from this process*). So
    the driver would look for its raylet on the interface address and never join a cluster
    bound to 127.0.0.1 (or a local Ray would bind the interface address). The variable is set
    here, in this process only, just before Ray is first imported and only for the loopback;
    nothing is set when ``stereoforge`` is imported. If Ray was imported before without it,
    the run stops with the fix instead of waiting for ever.
    """
    from stereoforge.errors import BackendError

    loopback = on_loopback(address)
    if loopback and "ray" not in sys.modules:
        os.environ.setdefault(RAY_LOOPBACK_ENV, "0")
    try:
        import ray
    except ImportError as exc:
        raise RuntimeError("engine='ray' needs Ray: pip install ray (or use engine='local')"
                           ) from exc
    if loopback and not ray.is_initialized() and os.environ.get(RAY_LOOPBACK_ENV) != "0":
        where = "a local Ray" if address is None else f"the Ray cluster at {address}"
        raise BackendError(
            f"engine='ray': {where} is on the loopback, but Ray was imported in this process "
            f"without {RAY_LOOPBACK_ENV}=0, so it would use the machine's interface address "
            f"and never reach it; set {RAY_LOOPBACK_ENV}=0 in the environment before Ray is "
            "imported (or let run_dataset import it), or use the head's interface address")
    return ray


def ray_results(ray: Any, actor_cls: Any, task: Any, indices: Sequence[int], workers: int,
                 stall: float = RAY_STALL_TIMEOUT_S) -> Iterator[tuple[int, dict]]:
    """Run ``indices`` on ``workers`` actors, one task each at a time; replace dead actors and
    run their samples again. Yields ``(index, result)``; kills its actors at the end."""
    from collections import deque

    from stereoforge.errors import BackendError

    queue, idle = deque(indices), []
    starting: dict[Any, Any] = {}  # ready() ref -> actor
    running: dict[Any, tuple[Any, int]] = {}  # run() ref -> (actor, index)
    actors: list[Any] = []
    lost, max_lost = 0, 4 * workers

    def start() -> None:
        actor = actor_cls.remote(task)
        actors.append(actor)
        starting[actor.ready.remote()] = actor

    def died(index: int | None, exc: Exception) -> None:
        nonlocal lost
        lost += 1
        if index is not None:
            queue.appendleft(index)  # its sample runs again on another actor
        _log.warning("a Ray worker was lost (%s)%s; a new one starts", type(exc).__name__,
                     "" if index is None else f"; sample {index} runs again")
        if lost > max_lost:
            raise BackendError(f"engine='ray': {lost} Ray workers died during the run (last: "
                               f"{type(exc).__name__}); the samples finished so far are kept: "
                               "rerun the same command to finish the others") from exc
        start()

    def raise_cause(exc: Exception) -> None:
        cause = getattr(exc, "cause", None)
        if isinstance(cause, Exception):
            raise cause from None
        raise exc

    try:
        for _ in range(workers):
            start()
        while queue or running:
            while idle and queue:
                actor, index = idle.pop(), queue.popleft()
                running[actor.run.remote(index)] = (actor, index)
            done, _ = ray.wait([*running, *starting], num_returns=1, timeout=stall)
            if not done:
                if not running:
                    raise BackendError(f"engine='ray': no Ray worker could start within "
                                       f"{stall:g} s (too few free CPUs on the cluster?)")
                continue
            ref = done[0]
            if ref in starting:
                actor = starting.pop(ref)
                try:
                    ray.get(ref)
                except ray.exceptions.RayActorError as exc:
                    died(None, exc)
                except ray.exceptions.RayTaskError as exc:
                    raise_cause(exc)
                else:
                    idle.append(actor)
                continue
            actor, index = running.pop(ref)
            try:
                result = ray.get(ref)
            except ray.exceptions.RayActorError as exc:  # the actor, or its node, died
                died(index, exc)
                continue
            except ray.exceptions.RayTaskError as exc:
                raise_cause(exc)
            idle.append(actor)
            yield result
    finally:
        for actor in actors:
            ray.kill(actor)
