"""Compare two datasets (or any two folders of stereo files) file by file.

Each file present in both is compared as bytes first; files that differ are decoded by type and
classed as

- ``"encoding"``: the same content in other bytes: a PNG with the same pixels (another deflate
  library or version, see ``docs/datasets.md``), a ``.gz`` holding the same data, a JSON file
  with the same values, a tar shard whose members are the same;
- ``"hashes"``: a JSON file (a completion record, ``shards.json``) whose only differences are
  the ``bytes`` and ``sha256`` of files that themselves differ by encoding only;
- ``"content"``: anything else: how many pixels or values differ, by how much and where;
- ``"only_a"`` / ``"only_b"``: a file one side lacks.

So a dataset rendered twice on one machine compares with no difference at all, and the same
configuration rendered on two machines whose deflate libraries differ compares with
``encoding`` and ``hashes`` differences only: the same data (:func:`same_content`).

Tar shards (``--format webdataset``) are compared member by member (``shard.tar/member``).
"""

from __future__ import annotations

import dataclasses
import gzip
import io
import json
import tarfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["KINDS", "Difference", "compare_datasets", "compare_files", "same_content", "summarize"]

#: The kinds of :class:`Difference`, in the order :func:`summarize` counts them.
KINDS = ("content", "only_a", "only_b", "hashes", "encoding")
_HASH_KEYS = frozenset({"bytes", "sha256"})
_MAX_KEYS = 5  # differing JSON values named in a detail


@dataclasses.dataclass(frozen=True)
class Difference:
    """One file that is not byte-identical in the two datasets.

    Attributes
    ----------
    path : str
        Path relative to the dataset (``/``-separated); a tar member is ``shard.tar/member``.
    kind : str
        One of :data:`KINDS` (see the module docstring).
    detail : str
        What differs, for a person: counts, the largest difference, the first position.
    files : tuple of str
        For kind ``"hashes"``: the files (paths in the dataset) whose listed size or SHA-256
        differ.
    """

    path: str
    kind: str
    detail: str
    files: tuple[str, ...] = ()  #: kind ``"hashes"``: the files whose size/SHA-256 differ

    def __str__(self) -> str:
        return f"{self.path}: {self.detail}"


# --------------------------------------------------------------------------- decoded content
def _array_detail(a: np.ndarray, b: np.ndarray, what: str, unit: str = "") -> str | None:
    """``None`` if the arrays hold the same values, else what differs."""
    if a.shape != b.shape or a.dtype != b.dtype:
        return f"{what}s of shape {a.shape} {a.dtype} and {b.shape} {b.dtype}"
    if a.dtype.kind == "f":
        same = (a == b) | (np.isnan(a) & np.isnan(b))
    else:
        same = a == b
    if same.ndim == 3:  # channels: a pixel differs when any channel does
        same = same.all(axis=2)
    if same.all():
        return None
    diff = ~same
    first = tuple(int(i) for i in np.argwhere(diff)[0])
    with np.errstate(invalid="ignore", over="ignore"):
        gap = np.abs(a.astype(np.float64) - b.astype(np.float64))
    finite = gap[np.isfinite(gap)]
    largest = f", largest |difference| {finite.max():g}{unit}" if finite.size else ""
    where = f"row {first[0]}, column {first[1]}" if len(first) >= 2 else f"index {first[0]}"
    return (f"{int(diff.sum())} of {diff.size} {what}s differ{largest}; first at {where}: "
            f"{_value(a, first)} vs {_value(b, first)}")


def _value(a: np.ndarray, index: tuple[int, ...]) -> str:
    v = a[index]
    if isinstance(v, np.ndarray):  # a pixel's channels, a flow vector
        return str(v.tolist())
    return f"{v.item():g}" if a.dtype.kind == "f" else str(v.item())


def _png(data: bytes) -> np.ndarray:
    import cv2

    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ValueError("not a PNG OpenCV can decode")
    if image.ndim == 3:  # OpenCV's BGR(A) to RGB(A), the order people read
        image = image[..., [2, 1, 0, 3][:image.shape[2]]] if image.shape[2] >= 3 else image
    return image


def _pfm(data: bytes) -> np.ndarray:
    from matcher.io import decode_pfm

    return decode_pfm(data)


def _flo(data: bytes) -> np.ndarray:
    from matcher.io import decode_flo

    return decode_flo(data)


#: Suffix -> (decoder to an array, the name of one element, its unit).
_ARRAYS: dict[str, tuple[Callable[[bytes], np.ndarray], str, str]] = {
    ".png": (_png, "pixel", ""),
    ".pfm": (_pfm, "value", ""),
    ".flo": (_flo, "vector", " px"),
}


def _leaves(value: Any, path: tuple = ()) -> Iterable[tuple[tuple, Any]]:
    """``(path, value)`` of every scalar and empty container of a parsed JSON document."""
    if isinstance(value, Mapping) and value:
        for k in value:
            yield from _leaves(value[k], (*path, str(k)))
    elif isinstance(value, list) and value:
        for i, v in enumerate(value):
            yield from _leaves(v, (*path, i))
    else:
        yield path, value


def _json_value(value: Any) -> str:
    """A leaf as JSON text: ``1``, ``1.0`` and ``true`` stay three values ({} and [] two)."""
    return json.dumps(value)


def _hashed_file(doc: Any, path: tuple) -> str | None:
    """The file a ``bytes``/``sha256`` leaf describes: the key of its entry (completion records:
    ``files -> {name: {bytes, sha256}}``) or the entry's ``name`` (``shards.json``)."""
    entry = doc
    for key in path[:-1]:
        entry = entry[key]
    if isinstance(entry, Mapping) and isinstance(entry.get("name"), str):
        return entry["name"]
    return str(path[-2]) if len(path) >= 2 else None


def _json_detail(a: Any, b: Any) -> tuple[str, str, set[str]]:
    """(kind, detail, files whose hashes differ) of two parsed JSON documents."""
    la = {k: _json_value(v) for k, v in _leaves(a)}
    lb = {k: _json_value(v) for k, v in _leaves(b)}
    changed = sorted((k for k in la.keys() | lb.keys() if la.get(k) != lb.get(k)),
                     key=lambda k: tuple(map(str, k)))
    if not changed:
        return "encoding", "the same JSON values, formatted differently", set()
    names = [".".join(map(str, k)) for k in changed]
    listed = ", ".join(names[:_MAX_KEYS]) + (f" and {len(names) - _MAX_KEYS} more"
                                             if len(names) > _MAX_KEYS else "")
    if all(k and k[-1] in _HASH_KEYS and k in la and k in lb for k in changed):
        files = {f for k in changed if (f := _hashed_file(a, k)) is not None}
        return "hashes", f"only the sizes/SHA-256 of {', '.join(sorted(files))} differ", files
    return "content", f"{len(names)} JSON value(s) differ: {listed}", set()


def _text_detail(a: bytes, b: bytes) -> str:
    la, lb = a.splitlines(), b.splitlines()
    for n, (x, y) in enumerate(zip(la, lb), 1):
        if x != y:
            return f"line {n} differs: {x[:60]!r} vs {y[:60]!r}"
    return f"{len(la)} and {len(lb)} lines (one is the other's beginning)"


def _tar_members(data: bytes) -> dict[str, bytes]:
    with tarfile.open(fileobj=io.BytesIO(data)) as tar:
        return {m.name: tar.extractfile(m).read() for m in tar.getmembers() if m.isfile()}


def compare_files(path: str, a: bytes, b: bytes) -> list[Difference]:
    """The differences between two versions ``a`` and ``b`` of the file ``path`` (its suffix
    chooses the decoder); empty when the bytes are equal. A tar file gives one
    :class:`Difference` per differing member, or one ``"encoding"`` difference for the shard.

    Examples
    --------
    >>> compare_files("calib.txt", b"ndisp=64\\n", b"ndisp=64\\n")
    []
    >>> compare_files("d.pfm", b"Pf\\n2 1\\n-1\\n" + np.float32([1, 2]).tobytes(),
    ...               b"Pf\\n2 1\\n-1\\n" + np.float32([1, 3]).tobytes())[0].detail
    '1 of 2 values differ, largest |difference| 1; first at row 0, column 1: 2 vs 3'
    """
    if a == b:
        return []
    suffix = Path(path).suffix.lower()
    try:
        if suffix == ".gz":
            inner = compare_files(path[:-3], gzip.decompress(a), gzip.decompress(b))
            if not inner:
                return [Difference(path, "encoding", "the same data, compressed differently")]
            return [dataclasses.replace(d, path=path) for d in inner]
        if suffix == ".tar":
            return _compare_members(path, _tar_members(a), _tar_members(b))
        if suffix in _ARRAYS:
            decode, what, unit = _ARRAYS[suffix]
            detail = _array_detail(decode(a), decode(b), what, unit)
            if detail is None:
                return [Difference(path, "encoding", f"the same {what}s, encoded differently "
                                                     f"({len(a)} and {len(b)} bytes)")]
            return [Difference(path, "content", detail)]
        if suffix == ".json":
            kind, detail, files = _json_detail(json.loads(a), json.loads(b))
            return [Difference(path, kind, detail, tuple(sorted(files)))]
    except (ValueError, OSError, tarfile.TarError, EOFError) as exc:  # undecodable: bytes only
        return [Difference(path, "content", f"bytes differ ({len(a)} and {len(b)} bytes); "
                                            f"not decodable as {suffix}: {exc}")]
    if suffix in (".txt", ".csv", ".jsonl", ".toml"):
        return [Difference(path, "content", _text_detail(a, b))]
    offset = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    return [Difference(path, "content", f"bytes differ from offset {offset} ({len(a)} and "
                                        f"{len(b)} bytes)")]


def _compare_maps(a: Mapping[str, Any], b: Mapping[str, Any], read: Callable[[Any], bytes],
                  prefix: str = "") -> list[Difference]:
    """Names on one side only, then :func:`compare_files` of each name on both sides (``read``
    turns an entry into its bytes); a name is ``prefix + name``."""
    out = [Difference(prefix + n, "only_a", "only in A") for n in sorted(a.keys() - b.keys())]
    out += [Difference(prefix + n, "only_b", "only in B") for n in sorted(b.keys() - a.keys())]
    for name in sorted(a.keys() & b.keys()):
        out += compare_files(prefix + name, read(a[name]), read(b[name]))
    return out


def _compare_members(path: str, a: Mapping[str, bytes], b: Mapping[str, bytes]
                     ) -> list[Difference]:
    """The members of two versions of the tar file ``path``: one ``"encoding"`` difference for
    the shard when every differing member differs by encoding only."""
    out = _compare_maps(a, b, bytes, prefix=f"{path}/")
    if out and all(d.kind == "encoding" for d in out):
        names = [d.path.rsplit("/", 1)[-1] for d in out]
        shown = ", ".join(names[:3]) + (" ..." if len(names) > 3 else "")
        return [Difference(path, "encoding", f"the same members, {len(names)} of them encoded "
                                             f"differently: {shown}")]
    return out


def _explain_hashes(found: list[Difference]) -> list[Difference]:
    """A ``hashes`` difference stays one only if every file it names differs by encoding only;
    else it is a ``content`` difference."""
    encoded = {d.path for d in found if d.kind == "encoding"}
    return [dataclasses.replace(d, kind="content", detail=d.detail + " (not all of them differ "
                                "by encoding only)")
            if d.kind == "hashes" and not set(d.files) <= encoded else d for d in found]


# --------------------------------------------------------------------------- public API
def _files(root: Any) -> dict[str, Any]:
    return {p.relative_to(root).as_posix(): p for p in sorted(root.rglob("*")) if p.is_file()}


def compare_datasets(a: str | Path, b: str | Path) -> list[Difference]:
    """Every file of folders ``a`` and ``b`` that is not byte-identical, classed and explained.

    Parameters
    ----------
    a, b : str or Path
        Two folders (datasets made by :func:`synth.dataset.run.run_dataset`, ``render``
        outputs, ...), or fsspec URLs of datasets (:mod:`synth.dataset.storage.fs`).

    Returns
    -------
    list of Difference
        In path order; empty when the two hold the same bytes.

    Raises
    ------
    FileNotFoundError
        If ``a`` or ``b`` is not a folder.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from matcher.io import encode_png
    >>> a, b = (pathlib.Path(tempfile.mkdtemp()) for _ in range(2))
    >>> image = np.arange(12, dtype=np.uint8).reshape(3, 4)
    >>> _ = (a / "im0.png").write_bytes(encode_png(image, deflate="isal"))
    >>> _ = (b / "im0.png").write_bytes(encode_png(image, deflate="zlib"))
    >>> _ = (a / "calib.txt").write_text("ndisp=64\\n")
    >>> _ = (b / "calib.txt").write_text("ndisp=65\\n")
    >>> for d in compare_datasets(a, b):
    ...     print(d.kind, "|", d)
    content | calib.txt: line 1 differs: b'ndisp=64' vs b'ndisp=65'
    encoding | im0.png: the same pixels, encoded differently (... and ... bytes)
    """
    from synth.dataset.storage.fs import dataset_path

    roots = [dataset_path(x) for x in (a, b)]
    for name, root in zip("ab", roots):
        if not root.is_dir():
            raise FileNotFoundError(f"{name.upper()}: {root} is not a folder; give two dataset "
                                    "folders (or fsspec URLs) to compare")
    found = _compare_maps(_files(roots[0]), _files(roots[1]), lambda p: p.read_bytes())
    return sorted(_explain_hashes(found), key=lambda d: d.path)


def same_content(differences: Iterable[Difference]) -> bool:
    """Whether ``differences`` are all of encoding (the two datasets hold the same data).

    Examples
    --------
    >>> same_content([]), same_content([Difference("x.png", "encoding", "...")])
    (True, True)
    >>> same_content([Difference("x.png", "content", "1 of 4 pixels differ")])
    False
    """
    return all(d.kind in ("encoding", "hashes") for d in differences)


def summarize(differences: Iterable[Difference]) -> str:
    """One line: byte-identical, the same content, or how many files differ in content.

    Examples
    --------
    >>> summarize([])
    'byte-identical'
    >>> summarize([Difference("a.png", "encoding", ""), Difference("r.json", "hashes", "")])
    'the same content; 1 file(s) encoded differently, 1 record(s) listing their hashes'
    """
    differences = list(differences)
    if not differences:
        return "byte-identical"
    n = {k: sum(d.kind == k for d in differences) for k in KINDS}
    if same_content(differences):
        return (f"the same content; {n['encoding']} file(s) encoded differently, "
                f"{n['hashes']} record(s) listing their hashes")
    parts = [f"{n['content']} file(s) differ in content"] if n["content"] else []
    parts += [f"{n['only_a']} only in A"] if n["only_a"] else []
    parts += [f"{n['only_b']} only in B"] if n["only_b"] else []
    parts += [f"{n['encoding']} encoded differently"] if n["encoding"] else []
    return "different: " + ", ".join(parts)
