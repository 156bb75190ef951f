"""One MATCHER string for any stereo matcher: the built-ins, a Python callable, a program.

:func:`resolve_matcher` turns a string into a :class:`Matcher`:

- ``NAME`` or ``NAME:WINDOW``: a built-in method of :func:`matcher.match` (``ct``, ``sct``,
  ``cthw``, ``awct``, ``awsct``, ``bm``, ``sgbm``); the window defaults to 9. Run in this
  process.
- ``py:MODULE:FUNCTION`` or ``py:PATH/FILE.py:FUNCTION``: a Python callable
  ``f(left, right, *, max_disparity) -> (H, W) float array`` (inf or NaN = no estimate), called
  with the pair's (H, W, 3) uint8 RGB images. If the name is an object with OpenCV's
  ``compute(left, right)`` (``cv2.StereoBM_create(...)``, ``cv2.StereoSGBM_create(...)``), it is
  called with the RGB images, and with grey (BT.601) uint8 images if that raises (StereoBM takes
  grey only); an int16 result is OpenCV's 1/16-pixel fixed point (divided by 16), and negative
  values are "no estimate". The callable runs in a child process of its own (started with
  ``spawn`` on first use and kept for later calls), so a crash, even a segfault, and a hang (it
  is killed after ``timeout`` seconds and a fresh child started) are recorded, never fatal. The
  child is killed if this process dies (Linux ``PR_SET_PDEATHSIG``; Linux ties it to the
  *thread* that started the child, so a child started from a thread that then ends is killed
  too, and the next call starts a new one).
- ``learned:MODEL.pt``: a model file of the reference learned matcher (:mod:`matcher.learned`,
  made by ``stereoforge train``), run in this process through :func:`matcher.learned.match_learned`
  with the inference steps its header names; takes RGB or grey uint8 views. Needs PyTorch (the
  extra ``learn``); the file is read once, here, so a bad file fails before any pair is matched.
- ``cmd:TEMPLATE``: any program, a shell command line with ``{left}`` and ``{right}`` (PNG
  images the adapter writes), ``{out}`` (a PFM the program writes) or ``{out_png}`` (a KITTI-style
  16-bit PNG, disparity x 256, 0 = no estimate) and ``{max_disparity}``. Every path is
  substituted shell-quoted (:func:`shlex.quote`), so do not quote the placeholders yourself.
  Run with ``/bin/sh`` in a new session; on timeout the whole process group is killed. A
  non-zero exit status, a missing or unreadable output file are failures.

:meth:`Matcher.run` never raises: every failure (an exception, a timeout, a result of the wrong
shape or dtype) becomes :attr:`MatcherOutcome.error`, a one-line description of what the matcher
returned. :meth:`Matcher.__call__` raises :class:`MatcherFailure` instead.
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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from stereoforge.errors import ParameterError, StereoforgeError

__all__ = ["MatcherError", "MatcherFailure", "MatcherOutcome", "Matcher", "resolve_matcher",
           "BUILTIN_WINDOW"]

#: Window of a built-in ``NAME`` given without ``:WINDOW``.
BUILTIN_WINDOW = 9
_PLACEHOLDERS = ("left", "right", "out", "out_png", "max_disparity")


class MatcherError(ParameterError):
    """A MATCHER string does not resolve; the message says what was tried."""


class MatcherFailure(StereoforgeError):
    """A matcher crashed, timed out or returned something that is not a disparity map."""


@dataclass(frozen=True)
class MatcherOutcome:
    """What one call of a matcher gave.

    Attributes
    ----------
    disparity : (H, W) float32 array or None
        ``inf`` = no estimate (NaN from users becomes inf); None when ``error`` is set.
    seconds : float
        Wall time of the call (for ``py:`` matchers, inside the child process).
    error : str or None
        None = ok, else ``"crashed: ..."``, ``"timed out after 60 s"``,
        ``"returned shape (10, 12), expected (48, 64)"``, ...
    """

    disparity: np.ndarray | None
    seconds: float
    error: str | None


def _one_line(text: str, limit: int = 300) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= limit else line[:limit - 3] + "..."


def _describe(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"an array of shape {value.shape} and dtype {value.dtype}"
    return f"a {type(value).__name__}"


def check_disparity(value: Any, shape: tuple[int, int]) -> np.ndarray:
    """A matcher's result as (H, W) float32 with inf for no estimate; MatcherFailure otherwise."""
    if isinstance(value, tuple) and len(value) == 1:
        value = value[0]
    if not isinstance(value, np.ndarray):
        raise MatcherFailure(f"returned {_describe(value)}, expected a {shape} float array")
    if value.ndim == 3 and value.shape[2] == 1:
        value = value[:, :, 0]
    if value.shape != shape:
        raise MatcherFailure(f"returned shape {value.shape}, expected {shape}")
    if not (np.issubdtype(value.dtype, np.floating) or np.issubdtype(value.dtype, np.integer)) \
            or value.dtype == np.bool_:
        raise MatcherFailure(f"returned dtype {value.dtype}, expected a float (or integer) array")
    out = value.astype(np.float32)
    out[np.isnan(out)] = np.inf
    out[out == -np.inf] = np.inf
    return out


def _opencv_disparity(raw: np.ndarray) -> np.ndarray:
    if isinstance(raw, np.ndarray) and raw.dtype == np.int16:
        out = raw.astype(np.float32) / np.float32(16.0)
        out[raw < 0] = np.inf
        return out
    if isinstance(raw, np.ndarray) and np.issubdtype(raw.dtype, np.floating):
        out = raw.astype(np.float32)
        out[out < 0] = np.inf
        return out
    return raw


def _wrap_callable(target: Any) -> Callable[..., Any]:
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
            return _opencv_disparity(raw)
        return run
    return target


def _load_target(target: str, func: str) -> Any:
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
                               f"{type(exc).__name__}: {_one_line(exc)}") from None
    else:
        where = f"the module {target!r}"
        try:
            module = importlib.import_module(target)
        except ImportError as exc:
            raise MatcherError(f"py:{target}:{func}: tried importing {where} (sys.path "
                               f"and the current folder): {_one_line(exc)}; give a module on "
                               "sys.path or a path to a .py file") from None
        except Exception as exc:
            raise MatcherError(f"py:{target}:{func}: importing {where} raised "
                               f"{type(exc).__name__}: {_one_line(exc)}") from None
    obj: Any = module
    for part in func.split("."):
        if not hasattr(obj, part):
            names = sorted(n for n in dir(module) if not n.startswith("_"))[:20]
            raise MatcherError(f"py:{target}:{func}: {where} has no attribute {func!r}; "
                               f"its names: {', '.join(names) or 'none'}")
        obj = getattr(obj, part)
    if not callable(obj) and not callable(getattr(obj, "compute", None)):
        raise MatcherError(f"py:{target}:{func}: {func} is {_describe(obj)}, neither callable "
                           "nor an object with compute(left, right)")
    return obj


# --------------------------------------------------------------------------- python children
def _die_with_parent() -> None:
    """Ask Linux to kill this process when its parent dies (no-op elsewhere)."""
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            libc = ctypes.CDLL("libc.so.6", use_errno=True)
            libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        except OSError:
            pass


def _child_main(conn: Any, target: str, func: str, parent: int) -> None:  # pragma: no cover
    """Loop of a ``py:`` matcher's child process (runs in the child; coverage cannot see it)."""
    _die_with_parent()
    if os.getppid() != parent:
        return
    try:
        fn = _wrap_callable(_load_target(target, func))
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
            reply = ("raised", f"{type(exc).__name__}: {_one_line(exc)}")
        seconds = time.perf_counter() - start
        try:
            conn.send((*reply, seconds))
        except Exception as exc:  # unpicklable result
            conn.send(("raised", f"returned {type(reply[1]).__name__} that cannot be sent back "
                                 f"({type(exc).__name__})", seconds))


class _Child:
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
        proc = ctx.Process(target=_child_main, daemon=True,
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
def _run_program(template: str, left: np.ndarray, right: np.ndarray, max_disparity: int,
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
        for key in _PLACEHOLDERS:
            command = command.replace("{" + key + "}", values[key])
        start = time.perf_counter()
        proc = subprocess.Popen(command, shell=True, cwd=tmp, stdin=subprocess.DEVNULL,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                start_new_session=True, preexec_fn=_die_with_parent)
        try:
            _, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
            raise MatcherFailure(f"timed out after {timeout:g} s") from None
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            tail = _one_line(err.decode(errors="replace")[-400:]) or "no stderr"
            raise MatcherFailure(f"crashed: exit status {proc.returncode}: {tail}")
        use_png = "{out_png}" in template
        path = paths["out_png" if use_png else "out"]
        if not path.is_file():
            raise MatcherFailure(f"wrote no {'{out_png}' if use_png else '{out}'} file "
                                 f"(exit status 0)")
        try:
            disp = read_disparity(path, divisor=256.0) if use_png else read_pfm(path)
        except (StereoforgeError, OSError, ValueError) as exc:
            raise MatcherFailure(f"wrote an unreadable {path.name}: {_one_line(exc)}") from None
        return np.asarray(disp), seconds  # a PNG's 0 is already inf (no estimate)


# --------------------------------------------------------------------------- the matcher
@dataclass(frozen=True)
class Matcher:
    """A resolved MATCHER string (see :func:`resolve_matcher`).

    Attributes
    ----------
    spec : str
        The MATCHER string as given, e.g. ``"ct:9"``, ``"py:mod:f"``.
    name : str
        Short label for tables and plots.
    kind : {"builtin", "learned", "py", "cmd"}
    timeout : float
        Seconds per pair for ``py:`` and ``cmd:`` matchers.
    """

    spec: str
    name: str
    kind: str
    timeout: float = 60.0
    _target: tuple = field(default=(), repr=False)
    _child: Any = field(default=None, repr=False, compare=False)

    def _raw(self, left: np.ndarray, right: np.ndarray, max_disparity: int) -> tuple[Any, float]:
        if self.kind == "builtin":
            from matcher.match import match

            method, window = self._target
            start = time.perf_counter()
            try:
                res = match(left, right, method=method, window=window,
                            max_disparity=max_disparity)
            except Exception as exc:
                raise MatcherFailure(f"crashed: {type(exc).__name__}: {_one_line(exc)}") from None
            return res.disparity, time.perf_counter() - start
        if self.kind == "learned":
            from matcher.learned import match_learned

            start = time.perf_counter()
            try:
                res = match_learned(left, right, self._target[0], max_disparity=max_disparity)
            except Exception as exc:
                raise MatcherFailure(f"crashed: {type(exc).__name__}: {_one_line(exc)}") from None
            return res.disparity, time.perf_counter() - start
        if self.kind == "cmd":
            return _run_program(self._target[0], left, right, max_disparity, self.timeout)
        return self._child.call(left, right, max_disparity, self.timeout)

    def __call__(self, left: np.ndarray, right: np.ndarray, *, max_disparity: int) -> np.ndarray:
        """The (H, W) float32 disparity (inf = no estimate); raises :class:`MatcherFailure`."""
        left, right = np.ascontiguousarray(left), np.ascontiguousarray(right)
        value, _ = self._raw(left, right, max_disparity)
        return check_disparity(value, left.shape[:2])

    def run(self, left: np.ndarray, right: np.ndarray, *, max_disparity: int) -> MatcherOutcome:
        """Like calling the matcher, but every failure is returned as ``error``; never raises
        (except KeyboardInterrupt)."""
        start = time.perf_counter()
        try:
            left, right = np.ascontiguousarray(left), np.ascontiguousarray(right)
            value, seconds = self._raw(left, right, max_disparity)
            return MatcherOutcome(check_disparity(value, left.shape[:2]), float(seconds), None)
        except (MatcherFailure, MatcherError) as exc:
            return MatcherOutcome(None, time.perf_counter() - start, _one_line(exc))
        except Exception as exc:
            return MatcherOutcome(None, time.perf_counter() - start,
                                  f"crashed: {type(exc).__name__}: {_one_line(exc)}")

    def close(self) -> None:
        """Stop a ``py:`` matcher's child process (a later call starts a new one)."""
        if self._child is not None:
            self._child.stop()


def _builtin(spec: str, timeout: float) -> Matcher:
    from matcher.match import METHODS

    name, _, window_text = spec.partition(":")
    name = name.strip().lower()
    if name not in METHODS:
        raise MatcherError(
            f"matcher {spec!r}: tried a built-in method {name!r}: not one of {', '.join(METHODS)}; "
            "tried py:MODULE:FUNCTION, learned:MODEL.pt and cmd:TEMPLATE: the string starts with "
            "none of 'py:', 'learned:', 'cmd:'")
    window = BUILTIN_WINDOW
    if window_text:
        if not window_text.isdigit() or int(window_text) < 3 or int(window_text) % 2 == 0:
            raise MatcherError(f"matcher {spec!r}: the window after ':' must be an odd integer "
                               f">= 3, got {window_text!r}; e.g. {name}:9")
        window = int(window_text)
    if name == "bm" and window < 5:
        raise MatcherError(f"matcher {spec!r}: OpenCV StereoBM needs a window >= 5; use bm:5")
    return Matcher(spec=spec, name=f"{name}:{window}", kind="builtin", timeout=timeout,
                   _target=(name, window))


def _learned(spec: str, timeout: float) -> Matcher:
    path = spec[len("learned:"):].strip()
    if not path:
        raise MatcherError(f"matcher {spec!r}: a learned matcher is learned:MODEL.pt (a file made "
                           "by stereoforge train)")
    try:
        from matcher.learned import ModelError, load_model
    except ImportError as exc:
        raise MatcherError(f"matcher {spec!r}: learned matchers need PyTorch ({_one_line(exc)}); "
                           "install the extra: pip install 'stereoforge[learn]'") from None
    try:
        model = load_model(path)
    except (ModelError, FileNotFoundError) as exc:
        raise MatcherError(f"matcher {spec!r}: {exc}") from None
    return Matcher(spec=spec, name=f"learned:{Path(path).stem}", kind="learned", timeout=timeout,
                   _target=(model,))


def resolve_matcher(spec: str, *, timeout: float = 60.0) -> Matcher:
    """The :class:`Matcher` a MATCHER string names (see the module docstring).

    ``py:`` targets are imported here once to check them (and again in the child process that
    runs them); ``cmd:`` templates are checked for ``{left}``, ``{right}`` and an output.

    Raises
    ------
    MatcherError
        The string does not resolve; the message says what was tried.

    Examples
    --------
    >>> m = resolve_matcher("ct:5")
    >>> m.name, m.kind
    ('ct:5', 'builtin')
    >>> resolve_matcher("sad")
    Traceback (most recent call last):
    ...
    matcher.adapters.MatcherError: matcher 'sad': tried a built-in method 'sad': not one of ct, sct, cthw, awct, awsct, bm, sgbm; tried py:MODULE:FUNCTION, learned:MODEL.pt and cmd:TEMPLATE: the string starts with none of 'py:', 'learned:', 'cmd:'
    """
    if not isinstance(spec, str) or not spec.strip():
        raise MatcherError(f"matcher: expected a MATCHER string (NAME[:WINDOW], py:MODULE:FUNCTION, "
                           f"py:FILE.py:FUNCTION, learned:MODEL.pt or cmd:TEMPLATE), got {spec!r}")
    if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not timeout > 0:
        raise MatcherError(f"timeout: expected seconds > 0, got {timeout!r}")
    spec = spec.strip()
    if spec.startswith("py:"):
        rest = spec[3:]
        target, sep, func = rest.rpartition(":")
        if not sep or not target or not func:
            raise MatcherError(f"matcher {spec!r}: a Python matcher is py:MODULE:FUNCTION or "
                               "py:PATH/FILE.py:FUNCTION; the ':FUNCTION' part is missing")
        _load_target(target, func)
        label = f"{Path(target).stem if target.endswith('.py') else target}.{func}"
        return Matcher(spec=spec, name=label, kind="py", timeout=float(timeout),
                       _target=(target, func), _child=_Child(target, func))
    if spec.startswith("learned:"):
        return _learned(spec, float(timeout))
    if spec.startswith("cmd:"):
        template = spec[4:].strip()
        missing = [p for p in ("left", "right") if "{" + p + "}" not in template]
        if not ("{out}" in template or "{out_png}" in template):
            missing.append("out or out_png")
        if missing:
            raise MatcherError(f"matcher {spec!r}: a cmd: template needs the placeholders "
                               f"{{left}}, {{right}} and {{out}} (or {{out_png}}); missing: "
                               f"{', '.join('{' + m + '}' for m in missing)}")
        try:
            program = shlex.split(template)[0]
        except (ValueError, IndexError):
            raise MatcherError(f"matcher {spec!r}: the template is not a valid command line") from None
        return Matcher(spec=spec, name=Path(program).name, kind="cmd", timeout=float(timeout),
                       _target=(template,))
    return _builtin(spec, float(timeout))
