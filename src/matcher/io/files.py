"""Reading files that may come from elsewhere: regular files only, never blocking, within a
size, and inside the tree being read.

Every reader of :mod:`matcher.io` (images, PFM, ``calib.txt``, flow, the training codecs) and of
stereoforge's own records reads through :func:`read_file` or :func:`open_file`:

- a FIFO, a device, a socket or a folder where a file should be is refused with one line naming
  it, before it is opened (a FIFO would block a reader forever, ``/dev/zero`` never ends), and
  the file is opened without blocking and checked again on its descriptor (a swap between the
  check and the open is caught);
- a file larger than the limit (:data:`MAX_FILE_BYTES`, or the caller's) is refused before it is
  read;
- inside :func:`confined` (what :mod:`synth.formats` wraps every read of a tree in), a path that
  resolves outside the tree's root (``..``, an absolute path, a symbolic link leaving it) is
  refused before anything is opened.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

from stereoforge.errors import FormatError

__all__ = ["MAX_FILE_BYTES", "OutsideRootError", "check_inside", "confined", "open_file",
           "read_file", "regular_file"]

#: The largest file a reader takes unless told otherwise (a 2 GiB image or PFM is no stereo
#: sample; a larger one is damage or a trap).
MAX_FILE_BYTES = 1 << 31

_ROOT: contextvars.ContextVar[Path | None] = contextvars.ContextVar("stereoforge_root",
                                                                    default=None)
_KINDS = ((stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISDIR, "a folder"))


class OutsideRootError(FormatError):
    """A path of a tree resolves outside the tree's root."""


def _kind(mode: int) -> str:
    return next((what for test, what in _KINDS if test(mode)), "not a regular file")


@contextlib.contextmanager
def confined(root: str | os.PathLike[str]) -> Iterator[Path]:
    """Within the block, every :func:`read_file` / :func:`open_file` refuses a path that resolves
    outside ``root`` (:class:`OutsideRootError`). Nested blocks keep the outer root."""
    resolved = Path(root).resolve()
    token = _ROOT.set(_ROOT.get() or resolved)
    try:
        yield resolved
    finally:
        _ROOT.reset(token)


def check_inside(path: str | os.PathLike[str], root: str | os.PathLike[str] | None = None
                 ) -> Path:
    """``path`` resolved, if it lies inside ``root`` (default: the :func:`confined` root;
    symbolic links followed); ``path`` as it is when there is no root.

    Raises
    ------
    OutsideRootError
        It resolves outside (through ``..``, an absolute path or a link).
    """
    base = Path(root).resolve() if root is not None else _ROOT.get()
    if base is None:
        return Path(path)
    resolved = Path(path).resolve()
    if resolved != base and base not in resolved.parents:
        how = "a symbolic link to" if Path(path).is_symlink() else "a path leading to"
        raise OutsideRootError(f"{path}: {how} {resolved}, outside {base}: a tree's files must "
                               "be inside it; copy the file in, or give the folder it is in")
    return resolved


def regular_file(path: str | os.PathLike[str], *, what: str = "file") -> os.stat_result:
    """The ``stat`` of ``path`` if it is a regular file (checked without opening it).

    Raises
    ------
    FileNotFoundError
        No such file.
    FormatError
        A FIFO, a device, a socket or a folder (the message names which).
    """
    check_inside(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file") from None
    if not stat.S_ISREG(st.st_mode):
        raise FormatError(f"{path}: is {_kind(st.st_mode)}, not a regular file; the {what} must "
                          "be a regular file")
    return st


def open_file(path: str | os.PathLike[str], *, what: str = "file",
              limit: int | None = MAX_FILE_BYTES) -> BinaryIO:
    """``path`` opened for reading as :func:`regular_file` allows it, without blocking, and of
    at most ``limit`` bytes (None: any size).

    Raises
    ------
    FileNotFoundError, FormatError
        See :func:`regular_file`; also a file over ``limit``.
    """
    regular_file(path, what=what)
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    try:
        st = os.fstat(fd)  # what was opened, not what was checked
        if not stat.S_ISREG(st.st_mode):
            raise FormatError(f"{path}: is {_kind(st.st_mode)}, not a regular file; the {what} "
                              "must be a regular file")
        if limit is not None and st.st_size > limit:
            raise FormatError(f"{path}: {st.st_size:,} bytes, more than the {limit:,} a {what} "
                              "may have; check the file")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_file(path: str | os.PathLike[str], *, what: str = "file",
              limit: int | None = MAX_FILE_BYTES) -> bytes:
    """The bytes of ``path`` (:func:`open_file`'s checks).

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     os.mkfifo(f"{d}/pipe")
    ...     try:
    ...         read_file(f"{d}/pipe", what="disparity")
    ...     except ValueError as exc:
    ...         print(str(exc).split(": ", 1)[1])
    is a named pipe (FIFO), not a regular file; the disparity must be a regular file
    """
    with open_file(path, what=what, limit=limit) as f:
        return f.read()
