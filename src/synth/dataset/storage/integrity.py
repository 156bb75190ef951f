"""Completion records of dataset samples, and the check of a whole dataset against them.

A sample is complete when its record ``records/NNNNNN.json`` exists and every file it lists has the
listed size (and, when checked, SHA-256). The record is written last, once the sample's temporary
directory has been renamed into place: it never lists a file that was not fully written. It sits
outside the folders the stereo tools read (:mod:`synth.dataset.storage.layout`). Paths in a record
are relative to the dataset directory (``MiddEval3/trainingF/000003/im0.png``; the KITTI layout:
``training/image_2/000003_10.png``, ``training/samples/000003/scene.json``)::

    {"files": {"MiddEval3/trainingF/000003/calib.txt": {"bytes": 190, "sha256": "9f1c..."}, ...},
     "index": 3}

A resumed run checks sizes (cheap: one ``stat`` per file) and renders again every sample whose
record is missing, unreadable or contradicted; :func:`verify_dataset` (``stereoforge dataset
--verify DIR``) also checks the SHA-256 of every file and reports holes and extra files.
"""

from __future__ import annotations

import json
import re
import stat
from collections.abc import Iterable
from pathlib import Path, PurePosixPath

from matcher.io.files import OutsideRootError, check_inside, read_file

from stereoforge.errors import DatasetError
from synth._util.json_records import json_bytes
from synth.dataset.storage.layout import (METADATA, RECORDS, SAMPLE_DIR, check_layout,
                                          dataset_format, record_path, sample_dir,
                                          sample_parent)
from synth.formats import get_layout
from synth.dataset.storage.manifest import manifest_bytes, read_manifest
from synth.dataset.storage.shards import read_index, sha256
from synth.dataset.storage.fs import dataset_path

__all__ = ["completion_record", "sample_problems", "verify_dataset"]

_TMP_DIR = re.compile(r"^\.\d{6}\.tmp-\d+$")


def _shard_problems(root: Path, shards: list[dict], checksums: bool) -> list[str]:
    problems = []
    for s in shards:
        path = root / str(s.get("name"))
        if not path.is_file():
            problems.append(f"{path.name}: missing (listed in shards.json)")
        elif path.stat().st_size != s.get("bytes"):
            problems.append(f"{path.name}: {path.stat().st_size} bytes, shards.json says "
                            f"{s.get('bytes')} bytes (truncated or replaced)")
        elif checksums and sha256(path) != s.get("sha256"):
            problems.append(f"{path.name}: SHA-256 differs from shards.json (corrupt)")
    return problems


def completion_record(index: int, files: Iterable[tuple[str, Path]]) -> bytes:
    """The bytes of a sample's record: ``files`` are (path in the dataset, file to read) pairs.

    Names of one file (hard links: Middlebury's ``im1E.png`` and ``im1L.png`` repeating
    ``im1.png``, :func:`matcher.io.write_all_atomic`) are read and hashed once.
    """
    entries = {}
    digests: dict[tuple[int, int], str] = {}  # (device, inode) of a linked file -> SHA-256
    for name, path in sorted(files):
        st = path.stat()
        if st.st_nlink > 1 and st.st_ino:  # st_ino is 0 where a file system has none
            inode = (st.st_dev, st.st_ino)
            if inode not in digests:
                digests[inode] = sha256(path)
            digest = digests[inode]
        else:
            digest = sha256(path)
        entries[name] = {"bytes": st.st_size, "sha256": digest}
    return json_bytes({"files": entries, "index": index})


def _listed(root: Path, index: int) -> tuple[dict | None, str | None]:
    """The files a sample's record lists, or ``None`` and why there is no usable record."""
    path = record_path(root, index)
    try:
        record = json.loads(read_file(path, what="completion record", limit=1 << 24)
                            if isinstance(path, Path) else path.read_bytes())
        files = record["files"]
        if record["index"] != index or not isinstance(files, dict) or not all(
                isinstance(e, dict) and isinstance(e.get("bytes"), int)
                and isinstance(e.get("sha256"), str) for e in files.values()):
            raise ValueError("unexpected content")
    except FileNotFoundError:
        return None, f"{index:06d}: no completion record ({RECORDS}/{path.name}); the sample " \
                     "is incomplete"
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"{path}: unreadable completion record ({type(exc).__name__}: {exc})"
    return files, None


def _entry(root: Path, name: str) -> tuple[Path, str | None]:
    """The file a record names, and why it may not be read: an absolute path, a ``..``, or (in
    a local folder) a symbolic link that leaves the dataset; None when it is inside."""
    parts = PurePosixPath(name).parts
    if not name or PurePosixPath(name).is_absolute() or "\\" in name or ".." in parts:
        return root, ("{record} lists {name!r}, a path outside the dataset: the record was "
                      "edited; render the sample again (delete its folder and rerun)")
    path = root / name
    if isinstance(root, Path) and (path.is_symlink() or any(p.is_symlink() for p in
                                                             path.parents if root in p.parents)):
        try:
            check_inside(path, root)
        except OutsideRootError:
            return root, ("{name}: a link to a file outside the dataset, not the file its "
                          "record lists; render the sample again (delete its folder and rerun)")
    return path, None


def sample_problems(root: Path, fmt: str, index: int, *, checksums: bool = False) -> list[str]:
    """What is wrong with sample ``index`` of the dataset of format ``fmt`` in ``root`` (empty:
    complete).

    Sizes are always checked; the SHA-256 of every file too when ``checksums``.
    """
    if not sample_dir(root, fmt, index).is_dir():
        return [f"{index:06d}: missing"]
    files, why = _listed(root, index)
    if files is None:
        return [why]
    problems = []
    for name, entry in files.items():
        path, outside = _entry(root, name)
        if outside is not None:
            problems.append(outside.format(record=f"{RECORDS}/{index:06d}.json", name=name))
            continue
        try:
            st = path.stat()
        except OSError:
            problems.append(f"{name}: missing (listed in {RECORDS}/{index:06d}.json)")
            continue
        size = st.st_size
        if isinstance(path, Path) and not stat.S_ISREG(st.st_mode):
            problems.append(f"{name}: not a regular file (a named pipe, device or folder in "
                            "its place); render the sample again")
            continue
        if size != entry["bytes"]:
            problems.append(f"{name}: {size} bytes, its record says {entry['bytes']} bytes "
                            "(truncated or replaced)")
        elif checksums and sha256(path) != entry["sha256"]:
            problems.append(f"{name}: SHA-256 differs from its record (corrupt)")
    return problems


def verify_dataset(dataset_dir: str | Path, *, count: int | None = None,
                   checksums: bool = True) -> list[str]:
    """Problems of a whole dataset, one line each: holes, incomplete or corrupt samples, extra
    files, a stale manifest. Empty when the dataset is whole.

    Parameters
    ----------
    dataset_dir : str or Path
        A directory made by :func:`synth.dataset.run.run_dataset`.
    count : int, optional
        Samples ``0 .. count - 1`` are expected (default: up to the highest index present).
    checksums : bool
        Also compare the SHA-256 of every file with its record (default); else sizes only.

    Examples
    --------
    >>> import tempfile
    >>> verify_dataset(tempfile.mkdtemp())[0]
    '...: no dataset.json; not a dataset directory (made by run_dataset)'
    """
    root = dataset_path(dataset_dir)  # a folder or an fsspec URL (synth.dataset.storage.fs)
    if not (root / "dataset.json").is_file():
        return [f"{root}: no dataset.json; not a dataset directory (made by run_dataset)"]
    check_layout(root)  # the previous layout: one error naming `stereoforge dataset --upgrade`
    fmt = dataset_format(root)
    parent = sample_parent(root, fmt)
    folders = {int(d.name) for d in parent.iterdir() if d.is_dir() and SAMPLE_DIR.match(d.name)} \
        if parent.is_dir() else set()
    layout = get_layout(fmt)
    shards = [] if layout.capacity.sample_folders else read_index(root)
    packed = {int(r["index"]) for s in shards for r in s["records"]}
    present = sorted(folders | packed)
    last = max(present, default=-1) if count is None else count - 1
    problems: list[str] = _shard_problems(root, shards, checksums)
    listed: set[str] = set()
    for index in sorted(set(range(last + 1)) | set(present)):
        if index in packed and index not in folders:
            continue  # in a complete shard, checked above
        found = sample_problems(root, fmt, index, checksums=checksums)
        if found == [f"{index:06d}: missing"]:
            found = [f"{index:06d}: missing (a hole: the dataset has samples after it)"
                     if count is None else f"{index:06d}: missing (count is {count})"]
        problems += found
        files, _ = _listed(root, index) if index in folders else (None, None)
        listed |= set(files or ())
        if files is None and index in folders:  # reported above; its files are not extra
            folder = sample_dir(root, fmt, index)
            listed |= {p.relative_to(root).as_posix() for p in folder.rglob("*")}
    listed |= set(layout.finish_files([]))  # the whole dataset's files (scene lists, list files)
    owned = (layout.tools_root.split("/")[0], layout.sample_parent.split("/")[0])
    for top in dict.fromkeys(owned):  # every file there belongs to a sample's record
        if (root / top).is_dir():
            problems += [f"{rel}: extra file (no sample's record lists it)"
                         for rel in (p.relative_to(root).as_posix()
                                     for p in sorted((root / top).rglob("*")) if p.is_file())
                         if rel not in listed]
    if (root / RECORDS).is_dir():
        problems += [f"{RECORDS}/{p.name}: record of no sample folder (sample "
                     f"{p.stem} is missing)" if SAMPLE_DIR.match(p.stem) and p.suffix == ".json"
                     else f"{RECORDS}/{p.name}: extra file"
                     for p in sorted((root / RECORDS).iterdir())
                     if not (SAMPLE_DIR.match(p.stem) and p.suffix == ".json"
                             and int(p.stem) in folders)]
    for entry in sorted(root.iterdir()):
        if entry.name in METADATA or (entry.is_dir() and entry.name in (
                RECORDS, *owned)) or entry.name in {s["name"] for s in shards}:
            continue
        if _TMP_DIR.match(entry.name):
            problems.append(f"{entry.name}: stale temporary directory of an interrupted run "
                            "(the next run removes it)")
        else:
            problems.append(f"{entry.name}: extra {'directory' if entry.is_dir() else 'file'}")
    try:
        records = read_manifest(root)
    except DatasetError as exc:  # a sample.json that is not JSON: reported above, by its file
        return [*problems, f"manifest.jsonl, manifest.csv: not checked ({exc})"]
    jsonl, table = manifest_bytes(records)
    for name, want in (("manifest.jsonl", jsonl), ("manifest.csv", table)):
        path = root / name
        if not path.is_file() or path.read_bytes() != want:
            problems.append(f"{name}: does not match the samples' sample.json (rerun the "
                            "dataset command to rewrite it)")
    for rel, want in layout.finish_files([r["dir"] for r in records]).items():
        path = root / rel
        if not path.is_file() or path.read_bytes() != want:
            problems.append(f"{rel}: does not list the complete samples (rerun the dataset "
                            "command to rewrite it)")
    return problems
