"""Is numba's on-disk cache cold? Tell the user once that kernels compile, and for how long.

On a fresh install the first ``stereoforge dataset`` (or ``match``, ``study``, ``paper``) spends
10-18 s compiling numba kernels, most of it inside the workers, without a word. This module
finds out cheaply, without importing numba, whether the cached kernels of some source files
are missing: every ``@njit(..., cache=True)`` function of a file (found by parsing it) gets an
index file ``<stem>.<name>-<line>.py<XY>.nbi`` where numba keeps it (``NUMBA_CACHE_DIR``, else
the ``__pycache__`` beside the source, else the user-wide cache); a file none of whose kernels
has one was never compiled here.
:func:`compile_notice` prints one line before the work when all are missing (a first run) and
one line with numba's compile time after it; otherwise it prints nothing.

A stale index (source edited since) is not detected: numba then recompiles silently, as before.
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import importlib.util
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

__all__ = ["DATASET_KERNELS", "MATCHER_KERNELS", "compile_notice", "missing_kernels"]

#: Source files (package-relative) of the kernels a matcher run compiles.
MATCHER_KERNELS = ("matcher/_kernels/census.py", "matcher/_kernels/canny.py",
                   "matcher/_kernels/cthw.py", "matcher/_kernels/adaptive.py",
                   "matcher/_kernels/aggregate.py", "matcher/_kernels/select.py",
                   "matcher/_kernels/learned.py", "matcher/_kernels/grey.py")
#: Source files of the kernels a dataset sample compiles (occlusion mask, noise, the gamma's
#: power, grey, Canny).
DATASET_KERNELS = ("synth/pair.py", "synth/appearance/photometric.py",
                   "synth/appearance/_powf.py", "matcher/_kernels/grey.py",
                   "matcher/_kernels/canny.py")


def _source(rel: str) -> Path | None:
    package, _, rest = rel.partition("/")
    spec = importlib.util.find_spec(package)  # a top-level package: nothing is imported
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations))) / rest


def _cached_functions(source: Path) -> list[tuple[str, int]]:
    """``(name, first line)`` of the top-level ``cache=True`` numba functions of ``source``."""
    tree = ast.parse(source.read_text(encoding="utf-8"), filename=str(source))
    found = []
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.decorator_list:
            for deco in node.decorator_list:
                if isinstance(deco, ast.Call) and any(
                        k.arg == "cache" and isinstance(k.value, ast.Constant) and k.value.value is True
                        for k in deco.keywords):
                    found.append((node.name, node.decorator_list[0].lineno))  # co_firstlineno
                    break
    return found


def _cache_dir(source: Path) -> Path:
    """The one folder numba keeps the cache of ``source`` in (numba.core.caching's locators,
    first usable wins): ``NUMBA_CACHE_DIR``, else ``__pycache__`` beside a writable source,
    else the user-wide cache."""
    parent = os.path.dirname(os.path.abspath(source))
    subpath = "_".join([os.path.basename(parent), hashlib.sha1(parent.encode()).hexdigest()])
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"], subpath)
    if os.access(parent, os.W_OK):
        return Path(parent, "__pycache__")
    user = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(user, "numba", subpath)


def missing_kernels(sources: Sequence[str]) -> list[str]:
    """The files of ``sources`` none of whose cached numba kernels is in numba's cache.

    A file counts as cached when at least one of its ``cache=True`` functions has an index
    (which ones compile depends on the method and the inputs); on a fresh install every file
    is missing. Cheap: a parse of each file and a few ``stat`` calls, numba is not imported.

    Examples
    --------
    >>> isinstance(missing_kernels(MATCHER_KERNELS), list)
    True
    """
    tag = f"py{sys.version_info[0]}{sys.version_info[1]}.nbi"
    missing = []
    for rel in dict.fromkeys(sources):
        source = _source(rel)
        if source is None or not source.is_file():
            continue
        folder = _cache_dir(source)
        functions = _cached_functions(source)
        if functions and not any((folder / f"{source.stem}.{name}-{line}.{tag}").is_file()
                                 for name, line in functions):
            missing.append(rel)
    return missing


@contextlib.contextmanager
def compile_notice(sources: Sequence[str], echo: Callable[[str], None], *,
                   what: str = "numba kernels") -> Iterator[bool]:
    """Around work that compiles the kernels of ``sources``: say so first when the cache is cold.

    Cold means that no file of ``sources`` has a kernel in the cache (a first run; which of
    them compile depends on the method, so a partly filled cache says nothing). Yields whether
    the cache was cold. When it was, ``echo`` gets one line before the block
    (what compiles, that it happens once) and one after it with the seconds numba spent
    compiling in this process (numba's ``numba:compile`` events). Warm: no output.
    """
    missing = missing_kernels(sources)
    present = [rel for rel in dict.fromkeys(sources) if (src := _source(rel)) and src.is_file()]
    if not missing or missing != present:  # some kernels cached: not a first run, stay quiet
        yield False
        return
    echo(f"compiling {what} once (not in numba's cache yet: {', '.join(missing)}; later runs "
         "load them from the cache) ...")
    from numba.core import event

    compiled = [0.0]
    t0 = time.perf_counter()
    with event.install_timer("numba:compile", lambda s: compiled.__setitem__(0, compiled[0] + s)):
        yield True
    echo(f"compiled {what} in {compiled[0]:.1f} s ({time.perf_counter() - t0:.1f} s in all)")
