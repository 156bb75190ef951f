"""Where a dataset is written: a local folder, or any fsspec URL (``memory://``, ``s3://``, ...).

:func:`dataset_path` turns what the user passed as ``out`` into a path object:

- a local path or a ``file://`` URL -> :class:`pathlib.Path` (everything as before: temporary
  sample folders renamed into place, byte-range locks on ``.lock``: :mod:`synth.dataset.parts`);
- any other URL -> :class:`FsPath`, a small :class:`~pathlib.Path`-like view of one location of
  an fsspec filesystem, with just the methods the dataset code calls (``/``, ``name``, ``is_dir``,
  ``is_file``, ``exists``, ``iterdir``, ``rglob``, ``stat``, ``read_bytes``, ``open``,
  ``relative_to``, ``stem``, ``suffix``, ``unlink``, ``read_text``, ``mkdir``). The resume and
  verify code of :mod:`synth.dataset.storage.integrity` and :mod:`synth.dataset.storage.manifest`
  run unchanged on it.

fsspec is optional (``pip install 'stereoforge[storage]'``); a URL whose filesystem package is
missing (``s3://`` without ``s3fs``) raises :class:`~stereoforge.errors.DatasetError` naming the
package, before any work.

Commit of one sample (:func:`commit_sample`): the driver receives the sample's files as bytes
(path in the dataset -> bytes, the completion record ``records/NNNNNN.json`` among them) and writes them.
Into a local folder they go through the same temporary folder and rename as a local worker's.
Into an object store, where there is no rename, *atomic* means: every file first, the completion
record last. A sample whose record is missing or contradicts its files is rendered again by the
next run, exactly as in a folder; ``verify_dataset`` checks sizes and SHA-256 the same way.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path, PurePosixPath
from typing import IO, Any

from stereoforge.errors import DatasetError

__all__ = ["FsPath", "commit_sample", "dataset_path", "is_local", "remove_tree", "write_bytes"]

_EXTRA = "pip install 'stereoforge[storage]' (or pip install fsspec)"


def _filesystem(protocol: str, url: str) -> Any:
    try:
        import fsspec
    except ImportError:
        raise DatasetError(f"out={url!r}: writing to a URL needs fsspec; {_EXTRA}, or pass a "
                           "local directory") from None
    try:
        fsspec.get_filesystem_class(protocol)
    except ValueError:
        raise DatasetError(f"out={url!r}: fsspec knows no filesystem {protocol!r}; use a local "
                           "directory or a URL such as s3://bucket/prefix, gs://bucket/prefix, "
                           "memory://name") from None
    except ImportError as exc:
        from fsspec.registry import known_implementations

        package = known_implementations.get(protocol, {}).get("class", "").split(".")[0]
        hint = f"pip install {package}" if package else str(exc)
        raise DatasetError(f"out={url!r}: the {protocol}:// filesystem is not installed "
                           f"({exc}); {hint}") from None
    return fsspec.filesystem(protocol)


def dataset_path(out: str | os.PathLike[str]) -> Path | FsPath:
    """``out`` as a path: a :class:`~pathlib.Path` for local folders, else an :class:`FsPath`.

    Examples
    --------
    >>> dataset_path("file:///tmp/x"), dataset_path("data/x")
    (PosixPath('/tmp/x'), PosixPath('data/x'))
    >>> dataset_path("nosuchfs://bucket/x")
    Traceback (most recent call last):
    ...
    stereoforge.errors.DatasetError: out='nosuchfs://bucket/x': fsspec knows no filesystem ...
    """
    if isinstance(out, FsPath | Path):
        return out
    text = os.fspath(out)
    protocol, sep, rest = text.partition("://")
    if not sep or "/" in protocol:
        return Path(text)
    if protocol == "file":
        return Path(rest)
    _filesystem(protocol, text)
    from fsspec.core import url_to_fs

    fs, path = url_to_fs(text)
    return FsPath(fs, path, protocol)


def is_local(path: Path | FsPath) -> bool:
    """Whether ``path`` is a folder of this machine (workers may write into it themselves)."""
    return isinstance(path, Path)


class _Stat:
    def __init__(self, size: int) -> None:
        self.st_size = size


class FsPath:
    """A location on an fsspec filesystem, with the part of :class:`~pathlib.Path` datasets use.

    Examples
    --------
    >>> p = dataset_path("memory://doc-fspath")
    >>> (p / "a" / "b.txt").write_bytes(b"hi")
    2
    >>> sorted(x.name for x in p.iterdir()), (p / "a" / "b.txt").stat().st_size
    (['a'], 2)
    >>> str((p / "a" / "b.txt").relative_to(p))
    'a/b.txt'
    """

    def __init__(self, fs: Any, path: str, protocol: str) -> None:
        self.fs, self.path, self.protocol = fs, path.rstrip("/") or "/", protocol

    # -- naming
    def __truediv__(self, other: str | os.PathLike[str]) -> FsPath:
        return FsPath(self.fs, str(PurePosixPath(self.path) / os.fspath(other)), self.protocol)

    def __str__(self) -> str:
        return f"{self.protocol}://{self.path.lstrip('/')}"

    def __repr__(self) -> str:
        return f"FsPath({str(self)!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, FsPath) and (self.fs, self.path) == (other.fs, other.path)

    def __hash__(self) -> int:
        return hash((self.protocol, self.path))

    def __lt__(self, other: FsPath) -> bool:
        return self.path < other.path

    @property
    def name(self) -> str:
        return PurePosixPath(self.path).name

    @property
    def stem(self) -> str:
        return PurePosixPath(self.path).stem

    @property
    def suffix(self) -> str:
        return PurePosixPath(self.path).suffix

    @property
    def parent(self) -> FsPath:
        return FsPath(self.fs, str(PurePosixPath(self.path).parent), self.protocol)

    def relative_to(self, other: FsPath) -> PurePosixPath:
        return PurePosixPath(self.path).relative_to(other.path)

    # -- queries
    def exists(self) -> bool:
        return bool(self.fs.exists(self.path))

    def is_dir(self) -> bool:
        return bool(self.fs.isdir(self.path))

    def is_file(self) -> bool:
        return bool(self.fs.isfile(self.path))

    def stat(self) -> _Stat:
        try:
            info = self.fs.info(self.path)
        except FileNotFoundError:
            raise FileNotFoundError(2, "No such file", str(self)) from None
        return _Stat(int(info["size"]))

    def iterdir(self) -> Iterator[FsPath]:
        for name in sorted(self.fs.ls(self.path, detail=False)):
            child = FsPath(self.fs, name, self.protocol)
            if child.path != self.path:
                yield child

    def rglob(self, pattern: str) -> Iterator[FsPath]:
        if pattern != "*":
            raise ValueError(f"FsPath.rglob supports '*' only, got {pattern!r}")
        for name in sorted(self.fs.find(self.path, withdirs=True)):
            child = FsPath(self.fs, name, self.protocol)
            if child.path != self.path:
                yield child

    # -- content
    def read_bytes(self) -> bytes:
        return bytes(self.fs.cat_file(self.path))

    def read_text(self, encoding: str = "utf-8") -> str:
        return self.read_bytes().decode(encoding)

    def open(self, mode: str = "rb") -> IO[bytes]:
        return self.fs.open(self.path, mode)

    def write_bytes(self, data: bytes) -> int:
        self.fs.pipe_file(self.path, bytes(data))
        return len(data)

    def unlink(self, missing_ok: bool = False) -> None:
        if missing_ok and not self.fs.exists(self.path):
            return
        self.fs.rm(self.path)

    def mkdir(self, parents: bool = False, exist_ok: bool = False) -> None:
        self.fs.makedirs(self.path, exist_ok=True)


def write_bytes(path: Path | FsPath, data: bytes) -> None:
    """Write one whole file: atomically (temp name, rename) in a folder; one ``put`` on an
    object store (which shows either the old or the whole new object)."""
    if isinstance(path, Path):
        from matcher.io import atomic_write_bytes

        atomic_write_bytes(path, data, fsync=False)
    else:
        path.write_bytes(data)


def remove_tree(path: Path | FsPath) -> None:
    """Remove a file, or a folder and everything under it; nothing if it is not there."""
    if isinstance(path, Path):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
    elif path.exists():
        path.fs.rm(path.path, recursive=True)


def commit_sample(out: Path | FsPath, index: int, files: Mapping[str, bytes], *, folder: str,
                  record: str, commit_local: Callable[[Path, Path], None]) -> None:
    """Write sample ``index``'s files (path in the dataset -> bytes), its completion record last.

    ``folder`` is the sample's folder in the dataset (e.g. ``MiddEval3/trainingF/000003``) and
    ``record`` its completion record's path (``records/NNNNNN.json``). Into a folder the files
    go to ``.NNNNNN.tmp-<pid>/`` (laid out as a worker lays it out: a file ``<folder>/x`` as
    ``x``, any other, e.g. KITTI's shared ``training/...``, as itself), ``commit_local(tmp,
    out)`` moves them into place as a local worker does, then the record is written. Into an
    object store every file is put in its final place, the record after all of them.
    """
    if isinstance(out, Path):
        tmp = out / f".{index:06d}.tmp-{os.getpid()}"
        shutil.rmtree(tmp, ignore_errors=True)
        prefix = folder.rstrip("/") + "/"
        try:
            for name, data in files.items():
                if name == record:
                    continue
                dest = tmp / (name[len(prefix):] if name.startswith(prefix) else name)
                dest.parent.mkdir(parents=True, exist_ok=True)
                dest.write_bytes(data)
            commit_local(tmp, out)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        (out / record).parent.mkdir(parents=True, exist_ok=True)
        write_bytes(out / record, files[record])
        return
    for name in sorted(files):
        if name != record:
            (out / name).write_bytes(files[name])
    (out / record).write_bytes(files[record])
