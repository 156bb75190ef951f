"""Atomic file writes: a reader never sees a half-written file.

The bytes go to a temporary file in the destination's directory (same file system), are flushed
and ``fsync``-ed, then renamed over the destination with :func:`os.replace` (atomic on POSIX and
Windows). On any exception the temporary file is removed and the destination is untouched.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

__all__ = ["atomic_write_bytes", "claim_output", "save_figure_atomic", "write_all_atomic"]


def _default_mode() -> int:
    """Mode of a newly created file under the current umask (``mkstemp`` would give 0600)."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


def _temporary_affixes(path: Path) -> tuple[str, str]:
    """Prefix and suffix of the temporary names beside ``path`` (``.NAME.<token>.tmp``): those
    :func:`atomic_write_bytes` and :func:`write_all_atomic` rename into place and
    :func:`claim_output` sweeps."""
    return f".{path.name}.", ".tmp"


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, *, fsync: bool = True) -> Path:
    """Write ``data`` to ``path`` atomically.

    Parameters
    ----------
    path : str or path-like
        Destination; its directory must exist.
    data : bytes
        Full file content.
    fsync : bool, default True
        ``fsync`` the file before the rename, so that after a crash the destination holds either
        the old or the complete new content.

    Raises
    ------
    OSError
        If the write fails (no space left, read-only, ...); it names ``path``, the temporary
        file is gone and a previous ``path`` is untouched.

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = atomic_write_bytes(pathlib.Path(d, "x.txt"), b"hi")
    ...     p.read_bytes(), sorted(x.name for x in pathlib.Path(d).iterdir())
    (b'hi', ['x.txt'])
    """
    path = Path(path)
    try:
        prefix, suffix = _temporary_affixes(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=prefix, suffix=suffix)
    except OSError as exc:  # name the destination, not the temporary name
        raise OSError(exc.errno, exc.strerror, str(path)) from exc
    try:
        os.fchmod(fd, _default_mode())
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            if fsync:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError) and exc.filename in (None, tmp) and exc.errno is not None:
            # a failed write (ENOSPC, EIO) names no file: name the destination
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise
    return path


def save_figure_atomic(fig, path: str | os.PathLike[str], **savefig_kwargs) -> Path:
    """Render a matplotlib figure to PNG in memory, then write it with :func:`atomic_write_bytes`."""
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", **savefig_kwargs)
    return atomic_write_bytes(path, buf.getvalue(), fsync=False)


def write_all_atomic(files: dict[Path, bytes], *, fsync: bool = True) -> list[Path]:
    """Write several already-encoded files, each atomically, in the given order.

    Encoding everything before the first write means validation and encoding errors leave the
    destination untouched. A file whose content is the very ``bytes`` object of an earlier file
    of the same directory (``is``, not ``==``: a writer's deliberate repeat, such as
    Middlebury's ``im1E.png`` and ``im1L.png`` when they repeat ``im1.png``) becomes a hard link
    to that file, made atomically too: the same bytes, stored once. Where the file system
    refuses hard links it is written as the others are.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as d:
    ...     data = b"pixels"
    ...     a, b = write_all_atomic({pathlib.Path(d, "a"): data, pathlib.Path(d, "b"): data})
    ...     b.read_bytes() == data, a.stat().st_ino == b.stat().st_ino
    (True, True)
    """
    written: list[Path] = []
    first: dict[int, Path] = {}  # id of a bytes object -> the first file written with it
    for p, data in files.items():
        path = Path(p)
        source = first.get(id(data))
        if source is None or source.parent != path.parent or not _link_atomic(source, path):
            atomic_write_bytes(path, data, fsync=fsync)
            first.setdefault(id(data), path)
        written.append(path)
    return written


def _link_atomic(source: Path, path: Path) -> bool:
    """Make ``path`` a hard link to ``source`` (same directory) through a temporary name and a
    rename; ``False``, with nothing changed, where the file system refuses the link."""
    prefix, suffix = _temporary_affixes(path)
    tmp = path.parent / f"{prefix}{os.urandom(6).hex()}{suffix}"
    try:
        os.link(source, tmp)
    except OSError:
        return False
    try:
        os.replace(tmp, path)
    finally:  # a rename between two links of one file does nothing and keeps both names
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
    return True


@contextlib.contextmanager
def claim_output(path: str | os.PathLike[str], files: Sequence[str | os.PathLike[str]],
                 say: Callable[[str], None] | None = None) -> Iterator[None]:
    """Hold ``PATH.lock`` (an exclusive ``flock``) while a long job writes ``files``.

    A second job on the same ``path`` fails at once, naming it. Once the lock is held, the
    temporary files :func:`atomic_write_bytes` left for ``files`` when a job was killed
    mid-write (``kill -9``, the OOM killer) are leftovers of a dead job: they are removed (and
    ``say`` reports how many). The lock file is removed on the way out.

    Raises
    ------
    FileExistsError
        Another process holds the lock.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> with tempfile.TemporaryDirectory() as d:
    ...     out = pathlib.Path(d, "m.pt")
    ...     _ = pathlib.Path(d, ".m.pt.abc123.tmp").write_bytes(b"half")
    ...     with claim_output(out, [out], print):
    ...         sorted(p.name for p in pathlib.Path(d).iterdir())
    removed 1 temporary file(s) of an interrupted run beside m.pt
    ['m.pt.lock']
    """
    import fcntl

    path = Path(path)
    lock = Path(f"{path}.lock")
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, _default_mode())
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FileExistsError(f"{path}: another process is writing it (it holds {lock}); "
                                  "wait for it to end or choose another --out") from None
        stale = [p for f in map(Path, files)
                 for p in f.parent.glob("*".join(_temporary_affixes(f)))]
        for p in stale:
            p.unlink(missing_ok=True)
        if stale and say is not None:
            say(f"removed {len(stale)} temporary file(s) of an interrupted run beside {path.name}")
        yield
    finally:
        with contextlib.suppress(FileNotFoundError):
            lock.unlink()
        os.close(fd)
