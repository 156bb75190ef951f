"""The driver side of the Ray engine: importing Ray on the loopback, joining (or starting) the
cluster, and running samples on actors with retries (:func:`synth.dataset.engine.tasks.run_tasks`
with ``engine="ray"``).

Each actor runs one task at a time; an actor that dies (its node lost) is replaced and its
sample goes back to the queue, so no sample is lost (at most ``4 * workers`` losses per run).
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, nullcontext
from typing import Any

__all__ = ["RAY_CONNECT_TIMEOUT_S", "RAY_LOOPBACK_ENV", "RAY_STALL_TIMEOUT_S",
           "check_ray_address", "import_ray", "on_loopback", "ray_connection", "ray_results"]

_log = logging.getLogger(__name__)

#: Ray reads this once, as it is imported: "0" keeps a node IP of 127.0.0.1 as it is.
RAY_LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
#: Seconds without a running sample and without a worker starting before the run gives up
#: (read when :func:`ray_results` is called: a test may set it lower).
RAY_STALL_TIMEOUT_S = 300.0
#: Seconds a Ray cluster address may take to answer before the run gives up.
RAY_CONNECT_TIMEOUT_S = 30.0
#: Ray's attempts to reach the GCS of an address, read as ``ray.init`` runs
#: (``ray/_private/node.py``, ``_init_gcs_client``; default ``RAY_NUM_REDIS_GET_RETRIES``, 20).
_GCS_ATTEMPTS_ENV = "RAY_gcs_server_port_wait_time_s"


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


def check_ray_address(address: str, *, timeout: float = RAY_CONNECT_TIMEOUT_S) -> None:
    """Check that the Ray cluster at ``address`` answers within ``timeout`` s.

    ``address`` is ``HOST:PORT`` (the head's GCS), or ``auto``/``ray://...``, which Ray resolves
    itself (they are not checked here). An address that does not answer raises
    :class:`~stereoforge.errors.BackendError` naming it, instead of Ray waiting for ever.

    Examples
    --------
    >>> check_ray_address("127.0.0.1:1", timeout=2)
    Traceback (most recent call last):
    ...
    stereoforge.errors.BackendError: engine='ray': no Ray cluster answers at 127.0.0.1:1 ...
    """
    import socket

    from stereoforge.errors import BackendError

    if address == "auto" or "://" in address:
        return
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit() or not host:
        raise ValueError(f"address: expected HOST:PORT of a Ray head (e.g. 127.0.0.1:6379), "
                         f"'auto' or a ray:// URL, got {address!r}")
    host = host.strip("[]")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout):
            pass
    except OSError as exc:
        raise BackendError(
            f"engine='ray': no Ray cluster answers at {address} ({exc.strerror or exc} within "
            f"{timeout:g} s); start one (ray start --head --node-ip-address=127.0.0.1) or fix "
            "--address") from None


@contextmanager
def _one_gcs_attempt() -> Iterator[None]:
    """While ``ray.init`` joins an address: one attempt at its GCS instead of Ray's 20.

    A port that answers but is no Ray GCS (another program, a head with token authentication
    the driver does not send) costs Ray about 40 s an attempt (5 s to connect, 5 s for the
    pubsub channel, 30 s for the cluster ID: Ray's ``gcs_rpc_server_connect_timeout_s`` and
    ``py_gcs_connect_timeout_s``; measured: 41 s), so its 20 attempts waited about 14 minutes;
    a live GCS answers the first one. A ``RAY_gcs_server_port_wait_time_s`` already set is
    kept. Never for a local Ray: its head reads the variable too (how long its GCS may take to
    start).
    """
    if _GCS_ATTEMPTS_ENV in os.environ:
        yield
        return
    os.environ[_GCS_ATTEMPTS_ENV] = "1"
    try:
        yield
    finally:
        os.environ.pop(_GCS_ATTEMPTS_ENV, None)


@contextmanager
def ray_connection(address: str | None, *, workers: int = 1,
                   timeout: float = RAY_CONNECT_TIMEOUT_S) -> Iterator[Any]:
    """Ray, joined to the cluster at ``address`` (or a new local Ray) for the ``with`` block.

    An ``address`` is checked first (:func:`check_ray_address`, ``timeout`` s), then joined;
    a port that answers but fails Ray's handshake raises
    :class:`~stereoforge.errors.BackendError` within about 45 s (see :func:`_one_gcs_attempt`).
    Without ``address`` a local Ray of ``workers`` CPUs starts on 127.0.0.1. What this call
    started or joined is shut down at the end of the block; a Ray this process had already
    initialized is used as it is and left running. Yields the ``ray`` module.
    """
    from stereoforge.errors import BackendError

    ray = import_ray(address)
    started = not ray.is_initialized()
    if started:
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
        if address is None:
            # a new local Ray of our own (not whatever cluster runs on this machine), on the
            # loopback only (never the machine's interface address)
            kwargs.update(num_cpus=workers, _node_ip_address="127.0.0.1")
        else:
            check_ray_address(address, timeout=timeout)
        joining = nullcontext() if address is None else _one_gcs_attempt()
        try:
            with joining:
                ray.init(address=address or "local", **kwargs)
        except ConnectionError as exc:  # the port answered, Ray's handshake did not
            raise BackendError(
                f"engine='ray': {exc}. If the head was started with token authentication (Ray "
                "enables it when ~/.ray/auth_token exists), set RAY_AUTH_MODE=token (and the "
                "token: ~/.ray/auth_token or RAY_AUTH_TOKEN) for this command; else check that "
                "--address is the head's GCS port and that both run the same Ray version"
            ) from None
    try:
        yield ray
    finally:
        if started:
            ray.shutdown()


def ray_results(ray: Any, actor_cls: Any, task: Any, indices: Sequence[int], workers: int,
                 stall: float | None = None) -> Iterator[tuple[int, dict]]:
    """Run ``indices`` on ``workers`` actors, one task each at a time; replace dead actors and
    run their samples again. Yields ``(index, result)``; kills its actors at the end.

    If for ``stall`` s (default :data:`RAY_STALL_TIMEOUT_S`, read at the call) no actor became
    ready and none is running a sample (the cluster has no free CPU for them), raises
    :class:`~stereoforge.errors.BackendError`.
    """
    from collections import deque

    from stereoforge.errors import BackendError

    stall = RAY_STALL_TIMEOUT_S if stall is None else stall
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
