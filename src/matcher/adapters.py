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
- ``learned:MODEL.pt`` or ``learned:MODEL.pt?device=DEVICE``: a model file of the reference
  learned matcher (:mod:`matcher.learned`, made by ``stereoforge train``), run in this process
  through :func:`matcher.learned.match_learned` with the inference steps its header names; takes
  RGB or grey uint8 views. ``DEVICE`` is ``auto`` (CUDA where torch sees a GPU, else the CPU),
  ``cpu``, ``cuda`` or ``cuda:N``; without ``?device=`` the environment variable
  ``STEREOFORGE_DEVICE`` names it, else ``auto``. Needs PyTorch (the extra ``learn``); the file
  is read and the device checked once, here, so a bad file or a device torch cannot use fails
  before any pair is matched.
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

import os
import shlex
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from matcher.failures import MatcherError, MatcherFailure, describe, one_line
from matcher.processes import PythonChild, load_target, run_program

__all__ = ["MatcherError", "MatcherFailure", "MatcherOutcome", "Matcher", "resolve_matcher",
           "BUILTIN_WINDOW"]

#: Window of a built-in ``NAME`` given without ``:WINDOW``.
BUILTIN_WINDOW = 9


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


def check_disparity(value: Any, shape: tuple[int, int]) -> np.ndarray:
    """A matcher's result as (H, W) float32 with inf for no estimate; MatcherFailure otherwise."""
    if isinstance(value, tuple) and len(value) == 1:
        value = value[0]
    if not isinstance(value, np.ndarray):
        raise MatcherFailure(f"returned {describe(value)}, expected a {shape} float array")
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
                raise MatcherFailure(f"crashed: {type(exc).__name__}: {one_line(exc)}") from None
            return res.disparity, time.perf_counter() - start
        if self.kind == "learned":
            from matcher.learned import match_learned

            start = time.perf_counter()
            try:
                model, device = self._target
                res = match_learned(left, right, model, max_disparity=max_disparity,
                                    device=device)
            except Exception as exc:
                raise MatcherFailure(f"crashed: {type(exc).__name__}: {one_line(exc)}") from None
            return res.disparity, time.perf_counter() - start
        if self.kind == "cmd":
            return run_program(self._target[0], left, right, max_disparity, self.timeout)
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
            return MatcherOutcome(None, time.perf_counter() - start, one_line(exc))
        except Exception as exc:
            return MatcherOutcome(None, time.perf_counter() - start,
                                  f"crashed: {type(exc).__name__}: {one_line(exc)}")

    def close(self) -> None:
        """Stop a ``py:`` matcher's child process (a later call starts a new one)."""
        if self._child is not None:
            self._child.stop()


def _builtin(spec: str, timeout: float) -> Matcher:
    from matcher.match import METHODS

    name, colon, window_text = spec.partition(":")
    name = name.strip().lower()
    if name not in METHODS:
        raise MatcherError(
            f"matcher {spec!r}: tried a built-in method {name!r}: not one of {', '.join(METHODS)}; "
            "tried py:MODULE:FUNCTION, learned:MODEL.pt and cmd:TEMPLATE: the string starts with "
            "none of 'py:', 'learned:', 'cmd:'")
    window = BUILTIN_WINDOW
    if colon and not window_text:
        raise MatcherError(f"matcher {spec!r}: no window after ':'; give one (e.g. {name}:9) or "
                           f"drop the ':' for the default ({name}:{BUILTIN_WINDOW})")
    if window_text:
        if not window_text.isdigit() or int(window_text) < 3 or int(window_text) % 2 == 0:
            raise MatcherError(f"matcher {spec!r}: the window after ':' must be an odd integer "
                               f">= 3, got {window_text!r}; e.g. {name}:9")
        window = int(window_text)
    if name == "bm" and window < 5:
        raise MatcherError(f"matcher {spec!r}: OpenCV StereoBM needs a window >= 5; use bm:5")
    return Matcher(spec=spec, name=f"{name}:{window}", kind="builtin", timeout=timeout,
                   _target=(name, window))


#: Environment variable naming the device of ``learned:`` matchers whose string names none.
DEVICE_ENV = "STEREOFORGE_DEVICE"


def _learned_options(spec: str, query: str) -> dict:
    """``KEY=VALUE&...`` after the model path's ``?``; the only key is ``device``."""
    options = {}
    for item in query.split("&"):
        key, sep, value = item.partition("=")
        key = key.strip().lower()
        if key != "device" or not sep or not value.strip():
            raise MatcherError(f"matcher {spec!r}: after '?' a learned matcher takes device=auto, "
                               f"cpu, cuda or cuda:N, got {item!r}; e.g. learned:MODEL.pt?device=cpu")
        options[key] = value.strip()
    return options


def _learned(spec: str, timeout: float) -> Matcher:
    path, sep, query = spec[len("learned:"):].strip().partition("?")
    path = path.strip()
    if not path:
        raise MatcherError(f"matcher {spec!r}: a learned matcher is learned:MODEL.pt (a file made "
                           "by stereoforge train)")
    options = _learned_options(spec, query) if sep else {}
    try:
        from matcher.learned import ModelError, load_model
        from matcher.learned.device import device_name
    except ImportError as exc:
        raise MatcherError(f"matcher {spec!r}: learned matchers need PyTorch ({one_line(exc)}); "
                           "install the extra: pip install 'stereoforge[learn]'") from None
    from stereoforge.errors import ParameterError

    if "device" in options:  # the string wins over the environment
        value, what = options["device"], f"matcher {spec!r}: device"
    else:
        value, what = os.environ.get(DEVICE_ENV, "").strip() or "auto", f"{DEVICE_ENV}"
    try:
        device = device_name(value, what)
    except ParameterError as exc:
        raise MatcherError(str(exc)) from None
    try:
        model = load_model(path)
    except (ModelError, FileNotFoundError) as exc:
        raise MatcherError(f"matcher {spec!r}: {exc}") from None
    return Matcher(spec=spec, name=f"learned:{Path(path).stem}", kind="learned", timeout=timeout,
                   _target=(model, device))


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
    matcher.failures.MatcherError: matcher 'sad': tried a built-in method 'sad': not one of ct, sct, cthw, awct, awsct, bm, sgbm; tried py:MODULE:FUNCTION, learned:MODEL.pt and cmd:TEMPLATE: the string starts with none of 'py:', 'learned:', 'cmd:'
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
        load_target(target, func)
        label = f"{Path(target).stem if target.endswith('.py') else target}.{func}"
        return Matcher(spec=spec, name=label, kind="py", timeout=float(timeout),
                       _target=(target, func), _child=PythonChild(target, func))
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
