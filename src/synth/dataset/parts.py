"""One dataset, several drivers: runs over index ranges ("parts") that share one output.

A run of :func:`synth.dataset.run.run_dataset` covers ``indices``, a :class:`range` of step 1
inside ``0 .. count - 1`` (default: all of it, a *whole* run). A run over a smaller range is a
*part*: several parts on disjoint ranges may write into the same folder or URL at the same time
(one driver each, e.g. one per machine), and since sample ``i``'s bytes depend only on the
configuration and ``i``, the samples are those of one whole run. The rules:

- **Lock per range.** In a local folder a run holds a write lock on the bytes of ``.lock`` that
  stand for its indices (byte ``i`` for sample ``i``, Linux's open-file-description locks,
  ``fcntl(F_OFD_SETLK)``): parts on disjoint ranges run side by side, a part whose range
  overlaps a running one is refused, and a whole run locks the whole file: it starts only when
  no other run writes the folder, and none starts beside it (as before parts: one run per
  folder; so the finishing run cannot start while a part runs). Where there are
  no such locks (not Linux) the same ranges are taken with process-owned ``lockf`` locks, which
  cannot tell two parts of one process apart. ``.lock`` stays an empty file: a folder written by
  parts holds exactly the files of one whole run. Object stores have no lock: give the drivers
  disjoint ranges.
- **dataset.json.** Byte :data:`HEADER_BYTE` of ``.lock`` (past every index) is held while a run
  creates or checks ``dataset.json``: in a folder the first part creates it, the others check it.
  On an object store two drivers starting at once may both write it, with the same bytes (one
  configuration, one header); a driver of another configuration is refused when it reads the
  header back.
- **Manifest.** Only a whole run writes ``manifest.jsonl``, ``manifest.csv`` and
  ``MiddEval3/official_train.txt`` (from the samples present, as always). A part leaves them as
  they are, so no part claims a complete dataset, and parts never race on those files. Once every
  part has ended, one whole run (the same command without ``--indices``) renders whatever is
  missing, nothing when the parts are complete, and writes them: the dataset then holds exactly
  the bytes of one whole run.
- ``--format webdataset`` fills its shards in index order from one run: a part is refused.
"""

from __future__ import annotations

import errno
import fcntl
import os
import re
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from stereoforge.errors import DatasetError, ParameterError, ParameterTypeError
from synth.formats import get_layout
from synth.dataset.storage.fs import FsPath, is_local

__all__ = ["HEADER_BYTE", "RunLock", "check_indices", "is_part", "lock_run", "parse_indices"]

#: The byte of ``.lock`` held while ``dataset.json`` is created or checked: past every index
#: (indices have six digits).
HEADER_BYTE = 1_000_000
_OFD = hasattr(fcntl, "F_OFD_SETLK")
_FLOCK = "hhqqi4x"  # struct flock: l_type, l_whence, l_start, l_len, l_pid (0 for OFD locks)
_BUSY = (errno.EAGAIN, errno.EACCES)  # what a lock held by another run fails with
_SLICE = re.compile(r"^\s*(\d*)\s*:\s*(\d*)\s*$")


def check_indices(indices: range | None, count: int, *, fmt: str | None = None) -> range:
    """The samples a run covers: ``indices`` checked against ``count``, or ``range(count)``;
    a part of a ``fmt="webdataset"`` dataset is refused (its shards fill in index order).

    Examples
    --------
    >>> check_indices(None, 4), check_indices(range(2, 4), 4)
    (range(0, 4), range(2, 4))
    >>> check_indices(range(2, 5), 4)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: indices: expected a range inside 0:4 (count is 4), got range(2, 5); ...
    """
    if indices is None:
        return range(count)
    if not isinstance(indices, range):
        raise ParameterTypeError(f"indices: expected a range such as range(1000, 2000), got "
                                 f"{type(indices).__name__} {indices!r}")
    if indices.step != 1:
        raise ParameterError(f"indices: expected consecutive samples (step 1), got {indices!r}; "
                             "give each driver a contiguous range such as range(1000, 2000)")
    return _checked(indices, count, fmt, repr(indices), ("indices", "count"))


def parse_indices(text: str, count: int, *, fmt: str | None = None) -> range:
    """``--indices START:STOP`` as a range (Python slice rules: STOP excluded; an omitted START is
    0, an omitted STOP is ``count``), checked as :func:`check_indices` does.

    Examples
    --------
    >>> parse_indices("1000:2000", 5000), parse_indices("4000:", 5000), parse_indices(":10", 5000)
    (range(1000, 2000), range(4000, 5000), range(0, 10))
    """
    match = _SLICE.match(str(text))
    if match is None:
        raise ParameterError(f"--indices: expected START:STOP (Python slice rules, e.g. 1000:2000, "
                             f"or 4000: up to --count), got {text!r}")
    start, stop = (int(g) if g else None for g in match.groups())
    indices = range(0 if start is None else start, count if stop is None else stop)
    return _checked(indices, count, fmt, repr(text), ("--indices", "--count"))


def _checked(indices: range, count: int, fmt: str | None, shown: str,
             names: tuple[str, str]) -> range:
    option, total = names
    if indices.start < 0 or indices.start >= count or indices.stop > count:
        raise ParameterError(f"{option}: expected a range inside 0:{count} ({total} is {count}), "
                             f"got {shown}; keep START below {count} and STOP at most {count}, "
                             f"or raise {total}")
    if indices.start >= indices.stop:
        raise ParameterError(f"{option}: expected a non-empty range START:STOP with START < STOP, "
                             f"got {shown}; e.g. {indices.start}:{count}")
    if fmt is not None and is_part(indices, count) and not get_layout(
            fmt).capacity.sample_folders:
        raise ParameterError(f"{option}: {shown} is a part of the dataset, but --format webdataset "
                             "fills its shards in index order from one run; drop the indices, or "
                             "split a middlebury or kitti dataset")
    return indices


def is_part(indices: range, count: int) -> bool:
    """Whether a run over ``indices`` covers less than the whole dataset of ``count`` samples."""
    return indices != range(count)


class RunLock:
    """The lock a run holds on ``out/.lock`` while it writes (nothing on an object store).

    ``part=None``: the whole file (a whole run); a range: its bytes. Use :meth:`header` around
    the creation or check of ``dataset.json``, and :meth:`close` at the end.
    """

    def __init__(self, out: Path | FsPath, part: range | None) -> None:
        self.out, self.part, self.fd = out, part, None
        if not is_local(out):
            return
        self.fd = os.open(out / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
        start, length = (0, 0) if part is None else (part.start, len(part))
        try:
            _set(self.fd, fcntl.F_WRLCK, start, length, wait=False)
        except OSError as exc:
            self.close()
            if exc.errno not in _BUSY:
                raise
            if part is None:
                raise DatasetError(
                    f"another run is writing {out} (it holds {out / '.lock'}); wait for it to "
                    "finish or stop it (a run over the whole dataset also waits for every "
                    "--indices part)") from None
            raise DatasetError(
                f"another run is writing {out}, some of samples {part.start}:{part.stop} "
                f"(it holds them in {out / '.lock'}); give each driver its own --indices range, "
                "or wait for that run to finish") from None

    @contextmanager
    def header(self) -> Iterator[None]:
        """Hold :data:`HEADER_BYTE` (a part; a whole run holds it already) for the block."""
        if self.fd is None or self.part is None:
            yield
            return
        _set(self.fd, fcntl.F_WRLCK, HEADER_BYTE, 1, wait=True)  # held briefly by other parts only
        try:
            yield
        finally:
            _set(self.fd, fcntl.F_UNLCK, HEADER_BYTE, 1, wait=False)

    def close(self) -> None:
        """Release the lock (closing the file releases it)."""
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def _set(fd: int, kind: int, start: int, length: int, *, wait: bool) -> None:
    """Take (``F_WRLCK``) or release (``F_UNLCK``) bytes ``start .. start + length - 1`` of ``fd``
    (``length`` 0: to the end, however far)."""
    if _OFD:
        command = fcntl.F_OFD_SETLKW if wait else fcntl.F_OFD_SETLK
        fcntl.fcntl(fd, command, struct.pack(_FLOCK, kind, os.SEEK_SET, start, length, 0))
        return
    operation = fcntl.LOCK_UN if kind == fcntl.F_UNLCK else fcntl.LOCK_EX
    fcntl.lockf(fd, operation if wait else operation | fcntl.LOCK_NB, length, start)


def lock_run(out: Path | FsPath, indices: range, count: int) -> RunLock:
    """Lock ``out`` for a run over ``indices`` of a dataset of ``count`` samples; raise
    :exc:`~stereoforge.errors.DatasetError` when another run holds any of them."""
    return RunLock(out, indices if is_part(indices, count) else None)
