"""Committing a rendered sample into a dataset: the rename of its folder, its completion record.

A sample is produced into a temporary folder (:func:`synth.dataset.sample.produce_sample`);
:func:`commit_local` renames it into place (the completion marker of a folder), and its
completion record ``records/NNNNNN.json`` (:mod:`synth.dataset.storage.integrity`) is written last.
Where the worker cannot write the output (Ray actors, fsspec URLs) it returns the files as bytes
(:func:`returned_files`) and the driver commits them (:func:`commit_files`, through
:func:`synth.dataset.storage.fs.commit_sample`).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from synth.dataset.storage.integrity import completion_record
from synth.dataset.storage.layout import record_path, sample_dir
from synth.dataset.storage.fs import FsPath, commit_sample, write_bytes
from synth.formats import get_layout

__all__ = ["commit_local", "dataset_files", "record_name", "write_record", "returned_files",
           "commit_files", "commit_returned"]


def commit_local(tmp: Path, out: Path, index: int, fmt: str) -> None:
    """Move a finished sample into place; the final rename is the completion marker.

    The files the layout places outside the sample folder (:attr:`Layout.placed
    <synth.formats.base.Layout.placed>`: KITTI's ``training/image_2/...``, the SceneFlow tree)
    are renamed to their paths in the dataset first, each atomically."""
    for top in get_layout(fmt).placed:
        shared = tmp / top
        if not shared.is_dir():
            continue
        for f in sorted(p for p in shared.rglob("*") if p.is_file()):
            target = out / f.relative_to(tmp)
            target.parent.mkdir(parents=True, exist_ok=True)
            os.replace(f, target)
        shutil.rmtree(shared)
    final = sample_dir(out, fmt, index)
    final.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.rename(tmp, final)
    except OSError:
        if not record_path(out, index).is_file():
            raise
        shutil.rmtree(tmp, ignore_errors=True)  # finished meanwhile by another process: same bytes
    # No fsync of `out`: the files are not fsynced either (see docs/datasets.md), so making the
    # rename durable would buy nothing after a power loss, and it costs ~3 ms per sample.


def dataset_files(tmp: Path, index: int, fmt: str) -> list[tuple[str, Path]]:
    """The files of a sample's temporary folder, as (path in the dataset, file) pairs."""
    layout = get_layout(fmt)
    return [(layout.dataset_path(path.relative_to(tmp).as_posix(), index), path)
            for path in sorted(p for p in tmp.rglob("*") if p.is_file())]


def record_name(index: int) -> str:
    """The completion record's path in the dataset (``records/NNNNNN.json``)."""
    return record_path(Path(), index).as_posix()


def write_record(out: Path | FsPath, index: int, record: bytes) -> None:
    """Write the completion record last, once the sample's files are in place."""
    path = record_path(out, index)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_bytes(path, record)


def returned_files(tmp: Path, index: int, fmt: str) -> dict[str, bytes]:
    """A rendered sample's files as a worker returns them (path in the dataset -> bytes), its
    completion record among them."""
    listed = dataset_files(tmp, index, fmt)
    files = {name: path.read_bytes() for name, path in listed}
    files[record_name(index)] = completion_record(index, listed)
    return files


def commit_files(out: Path | FsPath, index: int, files: dict[str, bytes], fmt: str) -> None:
    """Commit sample ``index``'s returned ``files`` (path in the dataset -> bytes, its
    completion record among them, as :class:`SampleTask` returns them) into ``out``: what the
    driver does for each sample of the Ray engine or a URL output."""
    commit_sample(out, index, files, folder=sample_dir(Path(), fmt, index).as_posix(),
                  record=record_name(index),
                  commit_local=lambda t, root: commit_local(t, root, index, fmt))


def commit_returned(tmp: Path, out: Path | FsPath, index: int, fmt: str) -> None:
    """What a sample costs the driver on the Ray engine or a URL output: the files of ``tmp``
    (a folder :func:`produce_sample` wrote) returned as bytes and committed into ``out``
    (``stereoforge bench dataset`` times it)."""
    commit_files(out, index, returned_files(tmp, index, fmt), fmt)
