"""The MATCHER kinds that run outside this process (:mod:`matcher.adapters`).

- ``py:`` callables: :func:`load_target` imports a module or a ``.py`` file and finds the name;
  :class:`PythonChild` runs it in a child process of its own (``spawn``, kept for later calls,
  restarted after a crash or a timeout, killed with its parent through :func:`die_with_parent`);
  :func:`wrap_callable` gives an OpenCV-style ``compute(left, right)`` object the callable form and
  :func:`opencv_disparity` reads its result (int16 = 1/16 pixel; negative = no estimate).
- ``cmd:`` programs: :func:`run_program` writes the two views as PNGs, runs the template with
  ``/bin/sh`` in a new session (its whole process group killed on timeout) and reads the PFM or
  16-bit PNG it wrote.

Every failure is a :class:`~matcher.failures.MatcherFailure` (or a
:class:`~matcher.failures.MatcherError` for a target that does not load) with a one-line message.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from matcher.failures import MatcherError, MatcherFailure, describe, one_line
from stereoforge.errors import StereoforgeError

__all__ = ["PLACEHOLDERS", "PythonChild", "child_main", "die_with_parent", "load_target",
           "opencv_disparity", "run_program", "wrap_callable"]

#: The placeholders of a ``cmd:`` template.
PLACEHOLDERS = ("left", "right", "out", "out_png", "max_disparity")


def opencv_disparity(raw: np.ndarray) -> np.ndarray:
    if isinstance(raw, np.ndarray) and raw.dtype == np.int16:
        out = raw.astype(np.float32) / np.float32(16.0)
        out[raw < 0] = np.inf
        return out
    if isinstance(raw, np.ndarray) and np.issubdtype(raw.dtype, np.floating):
        out = raw.astype(np.float32)
        out[out < 0] = np.inf
        return out
    return raw


def wrap_callable(target: Any) -> Callable[..., Any]:
    """``f(left, right, *, max_disparity)`` for a function or an OpenCV-style ``compute`` object."""
    compute = getattr(target, "compute", None)
    if callable(compute):
        import cv2

        def run(left: np.ndarray, right: np.ndarray, *, max_disparity: int) -> Any:
            try:
                raw = compute(left, right)
            except cv2.error:
                raw = compute(cv2.cvtColor(left, cv2.COLOR_RGB2GRAY),
                              cv2.cvtColor(right, cv2.COLOR_RGB2GRAY))
            return opencv_disparity(raw)
        return run
    return target


def load_target(target: str, func: str) -> Any:
    """The object ``func`` of a module name or a ``.py`` file; MatcherError naming what was tried."""
    if target.endswith(".py") or "/" in target or os.sep in target:
        path = Path(target).expanduser().resolve()
        if not path.is_file():
            raise MatcherError(f"py:{target}:{func}: tried the file {path}: it does not exist")
        name = f"_stereoforge_user_{abs(hash(str(path)))}"
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise MatcherError(f"py:{target}:{func}: tried the file {path}: not a Python file")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        where = f"the file {path}"
        try:
            spec.loader.exec_module(module)
        except Exception as exc:
            raise MatcherError(f"py:{target}:{func}: importing {where} raised "
                               f"{type(exc).__name__}: {one_line(exc)}") from None
    else:
        where = f"the module {target!r}"
        try:
            module = importlib.import_module(target)
        except ImportError as exc:
            raise MatcherError(f"py:{target}:{func}: tried importing {where} (sys.path "
                               f"and the current folder): {one_line(exc)}; give a module on "
                               "sys.path or a path to a .py file") from None
        except Exception as exc:
            raise MatcherError(f"py:{target}:{func}: importing {where} raised "
                               f"{type(exc).__name__}: {one_line(exc)}") from None
    obj: Any = module
    for part in func.split("."):
        if not hasattr(obj, part):
            names = sorted(n for n in dir(module) if not n.startswith("_"))[:20]
            raise MatcherError(f"py:{target}:{func}: {where} has no attribute {func!r}; "
                               f"its names: {', '.join(names) or 'none'}")
        obj = getattr(obj, part)
    if not callable(obj) and not callable(getattr(obj, "compute", None)):
        raise MatcherError(f"py:{target}:{func}: {func} is {describe(obj)}, neither callable "
                           "nor an object with compute(left, right)")
    return obj


# --------------------------------------------------------------------------- python children
def die_with_parent() -> None:
    """Ask Linux to kill this process when its parent dies (no-op elsewhere)."""
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:
            pass


def child_main(conn: Any, target: str, func: str, parent: int) -> None:  # pragma: no cover
    """Loop of a ``py:`` matcher's child process (runs in the child; coverage cannot see it)."""
    die_with_parent()
    if os.getppid() != parent:
        return
    try:
        fn = wrap_callable(load_target(target, func))
    except BaseException as exc:  # reported once, at the first call
        conn.send(("load", str(exc)))
        return
    conn.send(("ready", None))
    while True:
        try:
            left, right, max_disparity = conn.recv()
        except (EOFError, OSError):
            return
        start = time.perf_counter()
        try:
            value = fn(left, right, max_disparity=max_disparity)
            if isinstance(value, np.ndarray):
                value = np.ascontiguousarray(value)
            reply = ("ok", value)
        except BaseException as exc:
            reply = ("raised", f"{type(exc).__name__}: {one_line(exc)}")
        seconds = time.perf_counter() - start
        try:
            conn.send((*reply, seconds))
        except Exception as exc:  # unpicklable result
            conn.send(("raised", f"returned {type(reply[1]).__name__} that cannot be sent back "
                                 f"({type(exc).__name__})", seconds))


class PythonChild:
    """The child process running one ``py:`` matcher; restarted after a crash or a timeout."""

    def __init__(self, target: str, func: str) -> None:
        self.target, self.func = target, func
        self.proc: Any = None
        self.conn: Any = None

    def __getstate__(self) -> dict:  # a copy in another process starts its own child
        return {"target": self.target, "func": self.func, "proc": None, "conn": None}

    def _start(self, timeout: float) -> None:
        import multiprocessing as mp

        ctx = mp.get_context("spawn")
        parent_conn, child_conn = ctx.Pipe()
        proc = ctx.Process(target=child_main, daemon=True,
                           args=(child_conn, self.target, self.func, os.getpid()))
        proc.start()
        child_conn.close()
        self.proc, self.conn = proc, parent_conn
        if not parent_conn.poll(max(timeout, 30.0)):
            self.stop()
            raise MatcherFailure(f"timed out after {timeout:g} s loading the matcher")
        try:
            kind, message = parent_conn.recv()
        except EOFError:
            code = proc.exitcode
            self.stop()
            raise MatcherFailure(f"crashed: the child process died while loading the matcher "
                                 f"(exit status {code})") from None
        if kind == "load":
            self.stop()
            raise MatcherError(message)

    def stop(self) -> None:
        if self.proc is not None:
            if self.proc.is_alive():
                self.proc.kill()
            self.proc.join(5)
        if self.conn is not None:
            self.conn.close()
        self.proc = self.conn = None

    def call(self, left: np.ndarray, right: np.ndarray, max_disparity: int,
             timeout: float) -> tuple[Any, float]:
        if self.proc is None or not self.proc.is_alive():
            self.stop()
            self._start(timeout)
        start = time.perf_counter()
        self.conn.send((left, right, int(max_disparity)))
        if not self.conn.poll(timeout):
            self.stop()
            raise MatcherFailure(f"timed out after {timeout:g} s")
        try:
            kind, value, seconds = self.conn.recv()
        except (EOFError, OSError):
            code = self.proc.exitcode if self.proc is not None else None
            if self.proc is not None:
                self.proc.join(5)
                code = self.proc.exitcode
            self.stop()
            raise MatcherFailure(f"crashed: the matcher's process died (exit status {code}) after "
                                 f"{time.perf_counter() - start:.2f} s") from None
        if kind == "raised":
            raise MatcherFailure(f"crashed: {value}")
        return value, seconds


# --------------------------------------------------------------------------- programs
def run_program(template: str, left: np.ndarray, right: np.ndarray, max_disparity: int,
                 timeout: float) -> tuple[np.ndarray, float]:
    from matcher.io import encode_png, read_disparity, read_pfm

    with tempfile.TemporaryDirectory(prefix="stereoforge-cmd-") as tmp:
        paths = {"left": Path(tmp, "im0.png"), "right": Path(tmp, "im1.png"),
                 "out": Path(tmp, "disp0.pfm"), "out_png": Path(tmp, "disp0.png")}
        paths["left"].write_bytes(encode_png(left))
        paths["right"].write_bytes(encode_png(right))
        values = {k: shlex.quote(str(p)) for k, p in paths.items()}
        values["max_disparity"] = str(int(max_disparity))
        command = template
        for key in PLACEHOLDERS:
            command = command.replace("{" + key + "}", values[key])
        start = time.perf_counter()
        proc = subprocess.Popen(command, shell=True, cwd=tmp, stdin=subprocess.DEVNULL,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                start_new_session=True, preexec_fn=die_with_parent)
        try:
            _, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            raise MatcherFailure(f"timed out after {timeout:g} s") from None
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            tail = one_line(err.decode(errors="replace")[-400:]) or "no stderr"
            raise MatcherFailure(f"crashed: exit status {proc.returncode}: {tail}")
        use_png = "{out_png}" in template
        path = paths["out_png" if use_png else "out"]
        if not path.is_file():
            raise MatcherFailure(f"wrote no {'{out_png}' if use_png else '{out}'} file "
                                 f"(exit status 0)")
        try:
            disp = read_disparity(path, divisor=256.0) if use_png else read_pfm(path)
        except (StereoforgeError, OSError, ValueError) as exc:
            raise MatcherFailure(f"wrote an unreadable {path.name}: {one_line(exc)}") from None
        return np.asarray(disp), seconds  # a PNG's 0 is already inf (no estimate)
