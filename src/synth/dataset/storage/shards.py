"""``--format webdataset``: a dataset as tar shards in WebDataset's naming, resumable.

Layout::

    out/
      dataset.json  manifest.jsonl  manifest.csv  .lock
      shards.json             the complete shards: name, first index, count, bytes, records
      shard-000000.tar        000000.left.png 000000.right.png 000000.disp.pfm ...
      shard-000001.tar        ...
      .staging/NNNNNN/        samples rendered, not yet in a complete shard
      records/NNNNNN.json     completion records of the staged samples (storage.integrity)

Each sample is the Middlebury scene folder renamed to WebDataset fields (key ``NNNNNN``, the
sample index): ``left.png`` (im0), ``right.png`` (im1), ``disp.pfm`` (disp0GT), ``disp_right.pfm``
(disp1GT), ``mask.png`` (mask0nocc: 255 visible in both views, 128 occluded, 0 no ground
truth), ``sky.png`` (mask0sky, scenes with a sky only), ``calib.txt``, ``scene.json``,
``sample.json``; the member bytes are the Middlebury files' bytes. Shards fill in index order: a shard is closed when its members reach ``shard_size`` bytes
(so each is a little over it, the last one under it), written as ``.shard-K.tar.tmp`` and renamed
when complete, then listed in ``shards.json`` with its size and SHA-256 (the shard's completion
record; ``stereoforge dataset --verify`` checks it); only then are its staged samples and their
records removed. A staged sample counts as complete when its record matches its files. A run
killed at any point redoes only what no complete shard holds. The last shard of a run is short;
extending the dataset (a larger ``count``) re-renders that shard's samples and refills it, so the
shards are those an uninterrupted run writes. Tar members carry no time, owner or mode of the
machine (mtime 0, uid/gid 0, mode 0644): same seed, same bytes.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import json
import os
import shutil
import tarfile
from pathlib import Path

from collections.abc import Callable

from matcher.io import atomic_write_bytes
from stereoforge.errors import DatasetError, ParameterError
from synth._util.json_records import read_json_object
from synth.formats import get_layout
from synth.dataset.storage.fs import FsPath, dataset_path

__all__ = ["DEFAULT_SHARD_SIZE", "DISP_ENCODINGS", "FIELDS", "INDEX", "check_disp_encoding",
           "encode_member", "parse_size", "check_shard_option", "read_index",
           "packed_records", "sha256", "ShardWriter"]

#: About 1 GB per shard.
DEFAULT_SHARD_SIZE = 1_000_000_000
#: How the float maps (``.pfm`` members: disparities, depth, normals) are stored in a shard:
#: ``pfm`` the PFM bytes; ``pfm.gz`` the same bytes gzip-compressed (lossless; level 9, mtime 0,
#: so same seed, same bytes), field ``disp.pfm.gz``, which ``webdataset``'s default decoder
#: decompresses.
DISP_ENCODINGS = ("pfm", "pfm.gz")
#: Middlebury file -> WebDataset field, in the order the members are written.
FIELDS = (("im0.png", "left.png"), ("im1.png", "right.png"), ("disp0GT.pfm", "disp.pfm"),
          ("disp1GT.pfm", "disp_right.pfm"), ("mask0nocc.png", "mask.png"),
          ("depth0.pfm", "depth.pfm"), ("normals0.pfm", "normals.pfm"),
          ("instance0.png", "instance.png"), ("semantic0.png", "semantic.png"),
          ("mask1nocc.png", "mask_right.png"), ("mask0sky.png", "sky.png"),
          ("calib.txt", "calib.txt"), ("scene.json", "scene.json"), ("sample.json", "sample.json"))
#: The index of the complete shards, at the dataset's root.
INDEX = "shards.json"
_INDEX = INDEX


_UNITS = {"": 1, "B": 1, "KB": 10**3, "MB": 10**6, "GB": 10**9, "KIB": 2**10, "MIB": 2**20,
          "GIB": 2**30}


def parse_size(text: str) -> int:
    """Bytes from ``"1GB"``, ``"500MB"``, ``"64KiB"`` or a plain number.

    Examples
    --------
    >>> parse_size("1GB"), parse_size("1.5 MB"), parse_size("64KiB"), parse_size("4096")
    (1000000000, 1500000, 65536, 4096)
    """
    t = str(text).strip().upper().replace(" ", "")
    number = t.rstrip("KMGIB")
    try:
        value = float(number) * _UNITS[t[len(number):]]
    except (KeyError, ValueError):
        raise ParameterError(f"shard size: expected bytes such as 1GB, 500MB, 64KiB or 4096, got "
                         f"{text!r}") from None
    if not value >= 1:
        raise ParameterError(f"shard size: expected at least 1 byte, got {text!r}")
    return int(value)


def check_shard_option(fmt: str, shard_size: int | None) -> int | None:
    """The shard size to use for ``fmt``; a shard size with a format that has no shards is refused."""
    if get_layout(fmt).capacity.sample_folders:
        if shard_size is not None:
            raise ParameterError(f"shard_size applies to fmt='webdataset' only (tar shards); fmt={fmt!r} "
                             "writes one folder per sample: drop --shard-size or use --format "
                             "webdataset")
        return None
    if shard_size is None:
        return DEFAULT_SHARD_SIZE
    if isinstance(shard_size, bool) or not isinstance(shard_size, int) or shard_size < 1:
        raise ParameterError(f"shard_size must be a positive number of bytes, got {shard_size!r}")
    return shard_size


def check_disp_encoding(fmt: str, encoding: str | None) -> str | None:
    """The float-map encoding to use for ``fmt``; an encoding with a format of plain files (which
    the stereo tools read as ``.pfm``) is refused."""
    if encoding is None:
        return None
    if get_layout(fmt).capacity.sample_folders:
        raise ParameterError(f"disp_encoding applies to fmt='webdataset' only (tar shards); "
                             f"fmt={fmt!r} writes the .pfm files the stereo tools read: drop "
                             "--disp-encoding or use --format webdataset")
    if encoding not in DISP_ENCODINGS:
        raise ParameterError(f"disp_encoding: expected one of {', '.join(DISP_ENCODINGS)}, got "
                             f"{encoding!r}")
    return None if encoding == "pfm" else encoding


def encode_member(field: str, data: bytes, encoding: str | None) -> tuple[str, bytes]:
    """The shard member (field, bytes) of a sample file's bytes under ``encoding``.

    Examples
    --------
    >>> field, data = encode_member("disp.pfm", b"Pf\\n1 1\\n-1\\n\\0\\0\\0\\0", "pfm.gz")
    >>> field, gzip.decompress(data)
    ('disp.pfm.gz', b'Pf\\n1 1\\n-1\\n\\x00\\x00\\x00\\x00')
    """
    if encoding == "pfm.gz" and field.endswith(".pfm"):
        return f"{field}.gz", gzip.compress(data, compresslevel=9, mtime=0)
    return field, data


def read_index(root: str | Path) -> list[dict]:
    """The complete shards listed in ``root/shards.json`` (empty when there is none)."""
    path = dataset_path(root) / _INDEX
    if not path.is_file():
        return []
    shards = read_json_object(path, what="shard index", keys={"shards": list})["shards"]
    if not all(isinstance(s, dict) and isinstance(s.get("records"), list) for s in shards):
        raise DatasetError(f"{path}: expected a list of shard entries with their records; the "
                           "dataset directory was modified")
    return shards


def sha256(path: Path | FsPath) -> str:
    """Hex SHA-256 of a file (in a folder or on an fsspec filesystem); a local one must be a
    regular file (:func:`matcher.io.files.open_file`: a FIFO or ``/dev/zero`` is refused, not
    read forever)."""
    from matcher.io.files import open_file

    with (open_file(path, limit=None) if isinstance(path, Path) else path.open("rb")) as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def packed_records(root: str | Path) -> list[dict]:
    """The records of the samples held by complete shards (empty for other formats)."""
    return [r for shard in read_index(root) for r in shard["records"]]


def _member(name: str, data: bytes) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.size, info.mtime, info.mode = len(data), 0, 0o644
    info.uid = info.gid = 0
    info.uname = info.gname = ""
    return info


class ShardWriter:
    """Packs the staged samples of ``root`` into shards, in index order (the run's main process).

    ``complete(i)``: whether staged sample ``i`` is whole (its completion record matches);
    ``forget(i)``: drop the record of a sample once a complete shard holds it.
    """

    def __init__(self, root: Path, staging: Path, shard_size: int, count: int, *,
                 complete: Callable[[int], bool], forget: Callable[[int], None],
                 disp_encoding: str | None = None) -> None:
        self.root, self.staging, self.shard_size = root, staging, shard_size
        self.disp_encoding = disp_encoding
        self.complete, self.forget = complete, forget
        self.shards = read_index(root)
        last = self.shards[-1] if self.shards else None
        if last and not last["sealed"] and last["first"] + last["count"] < count:
            # the short last shard of a smaller run: its samples are redone and it is refilled
            self.shards.pop()
            self._save()
        listed = {s["name"] for s in self.shards}
        for p in root.glob("*shard-*.tar*"):
            if p.name not in listed:  # a shard renamed but not listed, or a temporary
                p.unlink()
        for s in self.shards:
            if not (root / s["name"]).is_file() or (root / s["name"]).stat().st_size != s["bytes"]:
                raise DatasetError(f"{root / s['name']} is missing or has another size than "
                                   f"{_INDEX} lists; delete it and its entry to redo it")
        self.next = self.shards[-1]["first"] + self.shards[-1]["count"] if self.shards else 0
        if staging.is_dir():
            for d in staging.iterdir():
                if d.name.isdigit() and int(d.name) < self.next:
                    shutil.rmtree(d)  # packed already; the run stopped before removing it
                    self.forget(int(d.name))
        self._tar: tarfile.TarFile | None = None
        self._tmp: Path | None = None
        self._members: list[tuple[int, dict]] = []
        self._bytes = 0

    def todo(self, count: int) -> list[int]:
        return [i for i in range(self.next, count) if not self.complete(i)]

    def _save(self) -> None:
        atomic_write_bytes(self.root / _INDEX, (json.dumps({"shards": self.shards}, indent=1,
                                                           sort_keys=True) + "\n").encode())

    def advance(self, count: int) -> None:
        """Pack every staged sample that follows the last packed one."""
        while self.next < count and self.complete(self.next):
            self._add(self.next)
            self.next += 1
            if self._bytes >= self.shard_size:
                self._close(sealed=True)

    def finish(self) -> None:
        """Write the short last shard (after a complete run)."""
        if self._members:
            self._close(sealed=False)
        if self.staging.is_dir() and not any(self.staging.iterdir()):
            self.staging.rmdir()

    def abort(self) -> None:
        """Drop the shard being filled (its samples stay staged)."""
        if self._tar is not None:
            self._tar.close()
            self._tmp.unlink(missing_ok=True)
            self._tar, self._members, self._bytes = None, [], 0
            self.next = self.shards[-1]["first"] + self.shards[-1]["count"] if self.shards else 0

    def _add(self, index: int) -> None:
        if self._tar is None:
            name = f"shard-{len(self.shards):06d}.tar"
            self._tmp = self.root / f".{name}.tmp-{os.getpid()}"
            self._tar = tarfile.open(self._tmp, "w", format=tarfile.USTAR_FORMAT)
        folder = self.staging / f"{index:06d}"
        for source, field in FIELDS:
            if (folder / source).is_file():
                name, data = encode_member(field, (folder / source).read_bytes(),
                                           self.disp_encoding)
                self._tar.addfile(_member(f"{index:06d}.{name}", data), io.BytesIO(data))
                self._bytes += len(data)
        self._members.append((index, json.loads((folder / "sample.json").read_text())))

    def _close(self, *, sealed: bool) -> None:
        assert self._tar is not None and self._tmp is not None
        self._tar.close()
        name = f"shard-{len(self.shards):06d}.tar"
        os.replace(self._tmp, self.root / name)
        first = self._members[0][0]
        self.shards.append({"name": name, "first": first, "count": len(self._members),
                            "bytes": (self.root / name).stat().st_size,
                            "sha256": sha256(self.root / name), "sealed": sealed,
                            "records": [r for _, r in self._members]})
        self._save()
        for index, _ in self._members:
            shutil.rmtree(self.staging / f"{index:06d}")
            self.forget(index)
        self._tar, self._tmp, self._members, self._bytes = None, None, [], 0

