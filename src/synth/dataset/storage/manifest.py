"""The manifest of a dataset: the records of its complete samples, as JSON lines and CSV.

``manifest.jsonl`` holds one record (``NNNNNN/sample.json``) per line, sorted by index;
``manifest.csv`` the same records flattened (``index, seed, dir, params.*, stats.*``).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

from synth._util.json_records import read_json_object
from synth.dataset.storage.layout import SAMPLE_DIR, sample_dirs
from synth.dataset.storage.shards import packed_records

__all__ = ["MODIFIED_FIX", "SAMPLE_DIR", "read_manifest", "manifest_bytes"]

#: The fix named by every error about a damaged dataset file.
MODIFIED_FIX = ("the dataset directory was modified or was not made by stereoforge; delete the "
                "damaged file's sample folder (or the whole directory) and run again")
_RECORD_KEYS = {"index": int, "seed": int, "dir": str, "params": dict, "stats": dict}


def read_manifest(dataset_dir: str | Path) -> list[dict]:
    """Records of the samples of a dataset, sorted by index (from each sample folder's ``sample.json``).

    Raises :exc:`~stereoforge.errors.DatasetError` on a dataset of the previous layout.

    Examples
    --------
    >>> import tempfile
    >>> read_manifest(tempfile.mkdtemp())
    []
    """
    records = [read_json_object(d / "sample.json", what="sample record", keys=_RECORD_KEYS,
                                fix=MODIFIED_FIX) for d in sample_dirs(dataset_dir)]
    records += packed_records(dataset_dir)  # --format webdataset: the samples in complete shards
    return sorted(records, key=lambda r: r["index"])


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value) if isinstance(value, float) else str(value)


def manifest_bytes(records: list[dict]) -> tuple[bytes, bytes]:
    """The bytes of ``manifest.jsonl`` and ``manifest.csv`` for ``records`` (sorted by index)."""
    jsonl = "".join(json.dumps(r, sort_keys=True) + "\n" for r in records)
    params = sorted({k for r in records for k in r["params"]})
    stats = sorted({k for r in records for k in r["stats"]})
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["index", "seed", "dir", *(f"params.{k}" for k in params),
                     *(f"stats.{k}" for k in stats)])
    for r in records:
        writer.writerow([r["index"], r["seed"], r["dir"],
                         *(_cell(r["params"].get(k)) for k in params),
                         *(_cell(r["stats"].get(k)) for k in stats)])
    return jsonl.encode(), buf.getvalue().encode()
