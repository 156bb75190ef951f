"""GL backend choice for :mod:`synth.render.renderer`: probing, platform lock, rasterizer threads.

Nothing here imports OpenGL: each backend is probed in a subprocess, and the platform PyOpenGL
is locked to is read from ``sys.modules``. PyOpenGL reads ``PYOPENGL_PLATFORM`` once, at its
first import; Mesa's llvmpipe reads ``LP_NUM_THREADS`` once, at the first context.
"""

from __future__ import annotations

import functools
import json
import numbers
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager

from stereoforge.errors import BackendError

__all__ = ["BACKENDS", "DEBIAN_FIX", "GLBackendError", "check_backend_name", "check_threads",
           "choose_backend", "driver_threads", "fix_line", "gl_renderer_string", "platform_in_use",
           "refuse_late_threads", "resolve_backend"]

#: Backends in the order ``backend="auto"`` tries them.
BACKENDS = ("egl", "osmesa")
#: The Debian packages that give each backend its libraries and Mesa's driver.
DEBIAN_FIX = {
    "egl": "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0",
    "osmesa": "apt-get install libosmesa6",
}


def fix_line(fix: str) -> str:
    """``fix: <command>``, labelled Debian's for an ``apt-get`` command."""
    return f"fix (Debian): {fix}" if fix.startswith("apt-get") else f"fix: {fix}"


class GLBackendError(BackendError):
    """No OpenGL backend could be started (the message names each one tried and the fix).

    ``fix``, where known, is the command that repairs it (``pip install ...`` for a missing
    Python package, ``apt-get install ...`` for a missing system library); the message ends with it.
    """

    def __init__(self, message: str, *, fix: str | None = None) -> None:
        super().__init__(message if fix is None else f"{message}\n  {fix_line(fix)}")
        self.problem, self.fix = message, fix


# Prints nothing but the renderer's name on success; on a GLBackendError, the tag then the
# problem and its fix as JSON (anything else fails with a traceback).
_PROBE_TAG = "stereoforge-probe-error:"
_PROBE = f"""
import json, sys
from synth.render.backend import GLBackendError
from synth.render.context import open_context
try:
    context = open_context(sys.argv[1])
except GLBackendError as exc:
    print({_PROBE_TAG!r} + json.dumps([exc.problem, exc.fix]))
    sys.exit(1)
from OpenGL import GL
print(GL.glGetString(GL.GL_RENDERER).decode())
context.destroy()
"""


#: GL_RENDERER of each backend whose probe succeeded in this process.
_RENDERERS: dict[str, str] = {}


@functools.cache
def probe_backend(backend: str) -> str | None:
    """Try ``backend`` in a subprocess; ``None`` if it starts, else the error and its fix."""
    env = dict(os.environ, PYOPENGL_PLATFORM=backend)
    # the probe imports synth.render.context: find it where this process did (a source checkout on
    # sys.path, not installed, included): the folder holding the synth package
    here = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env["PYTHONPATH"] = os.pathsep.join(p for p in (here, env.get("PYTHONPATH")) if p)
    try:
        out = subprocess.run(
            [sys.executable, "-c", _PROBE, backend],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
    except (OSError, subprocess.TimeoutExpired) as exc:  # pragma: no cover - defensive
        return f"probe failed to run: {exc}"
    if out.returncode == 0:
        lines = out.stdout.strip().splitlines()
        _RENDERERS[backend] = lines[-1] if lines else "unknown"
        return None
    tagged = [ln for ln in out.stdout.splitlines() if ln.startswith(_PROBE_TAG)]
    if tagged:
        problem, fix = json.loads(tagged[-1][len(_PROBE_TAG):])
    else:  # the driver failed in a way we do not recognise: the last line, the usual fix
        lines = [ln for ln in (out.stderr or out.stdout).strip().splitlines() if ln.strip()]
        problem, fix = (lines[-1] if lines else f"exit status {out.returncode}"), DEBIAN_FIX[backend]
    return problem if fix is None else f"{problem}\n    {fix_line(fix)}"


def gl_renderer_string(backend: str = "auto") -> str:
    """``GL_RENDERER`` of the backend a :class:`Renderer` would start here (probed, not started).

    Raises
    ------
    GLBackendError
        If no requested backend starts.
    """
    name = resolve_backend(backend)
    if name not in _RENDERERS:  # chosen without a probe (the platform was already locked):
        probe_backend.__wrapped__(name)  # probe once more, leaving the cached verdicts alone
    return _RENDERERS.get(name, "unknown")


def platform_in_use() -> str | None:
    """The PyOpenGL platform this process is locked to, or ``None`` if not chosen yet."""
    mod = sys.modules.get("OpenGL.platform")
    if mod is None or getattr(mod, "PLATFORM", None) is None:
        return None
    name = type(mod.PLATFORM).__name__.lower()
    for b in BACKENDS:
        if b in name:
            return b
    return name.replace("platform", "") or name


def resolve_backend(backend: str = "auto") -> str:
    """The GL backend a :class:`Renderer` would start here: ``"egl"`` or ``"osmesa"``.

    Each candidate is probed once per process, in a subprocess (so a broken driver cannot take
    this process down). A parent process can resolve once and hand the name to its workers,
    which then open ``Renderer(..., backend=name, probe=False)`` without probing again.

    Raises
    ------
    GLBackendError
        If no requested backend starts.
    """
    check_backend_name(backend)
    return choose_backend(backend)


def check_backend_name(backend: str) -> None:
    if backend not in ("auto",) + BACKENDS:
        raise ValueError(
            f"backend must be one of 'auto', 'egl', 'osmesa', got {backend!r}; "
            "use 'auto' to try EGL then OSMesa"
        )


def choose_backend(backend: str, *, probe: bool = True) -> str:
    """Pick the backend to start in this process (probing before any OpenGL import)."""
    wanted = list(BACKENDS) if backend == "auto" else [backend]
    locked = platform_in_use()
    if locked is not None:
        if locked in wanted:
            return locked
        hint = (f"use backend={locked!r} or 'auto', or" if locked in BACKENDS
                else "stereoforge supports only 'egl' and 'osmesa':")
        raise GLBackendError(
            f"backend={backend!r} is not available: PyOpenGL was already imported in this "
            f"process with the {locked!r} platform and cannot switch; {hint} create the Renderer "
            "in a fresh process before anything imports OpenGL (PyOpenGL reads "
            "PYOPENGL_PLATFORM once, at import)"
        )
    if not probe and backend != "auto":
        return backend
    failures = []
    for b in wanted:
        err = probe_backend(b)
        if err is None:
            return b
        failures.append(f"  {b}: {err}")
    raise GLBackendError(
        "no OpenGL backend could start; tried:\n" + "\n".join(failures)
    )


# llvmpipe's rasterizer threads: read from LP_NUM_THREADS once per process, when the first
# GL driver screen is created; recorded here at our first context so later requests can be checked.
DRIVER_THREADS: dict[str, str | None] = {}


def check_threads(threads: int | None) -> None:
    if threads is None:
        return
    if isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 0:
        raise ValueError(
            f"threads must be None (llvmpipe's default: one per core) or an int >= 0 "
            f"(0: rasterize in the calling thread), got {threads!r}"
        )


def refuse_late_threads(threads: int | None) -> None:
    if not DRIVER_THREADS or threads is None:
        return
    in_effect = DRIVER_THREADS["value"]
    if in_effect != str(int(threads)):
        shown = "llvmpipe's default (one per core)" if in_effect is None else in_effect
        raise ValueError(
            f"threads={threads} cannot take effect: this process already started the GL "
            f"driver with {shown} rasterizer threads, fixed for the life of the process; "
            "pass the same value (or None), or open the Renderer in a fresh process"
        )


@contextmanager
def driver_threads(threads: int | None) -> Iterator[None]:
    """``LP_NUM_THREADS`` set while this process starts its first GL context (the driver reads
    it then, once), restored after; recorded in ``DRIVER_THREADS``."""
    if DRIVER_THREADS:
        yield
        return
    before = os.environ.get("LP_NUM_THREADS")
    if threads is not None:
        os.environ["LP_NUM_THREADS"] = str(int(threads))
    try:
        yield
        DRIVER_THREADS["value"] = os.environ.get("LP_NUM_THREADS")
    finally:
        if before is None:
            os.environ.pop("LP_NUM_THREADS", None)
        else:
            os.environ["LP_NUM_THREADS"] = before
