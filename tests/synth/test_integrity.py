"""Completion records (``synth.dataset.storage.integrity``): hard links hashed once."""

from __future__ import annotations

import hashlib
import json
import os

from synth.dataset.storage import integrity


def test_names_of_one_file_are_hashed_once_and_recorded_as_copies_would_be(tmp_path,
                                                                           monkeypatch):
    (tmp_path / "im1.png").write_bytes(b"right view")
    os.link(tmp_path / "im1.png", tmp_path / "im1E.png")
    os.link(tmp_path / "im1.png", tmp_path / "im1L.png")
    (tmp_path / "im0.png").write_bytes(b"left view")
    (tmp_path / "copy.png").write_bytes(b"right view")  # equal bytes, its own file: hashed
    files = [(f"s/{p.name}", p) for p in sorted(tmp_path.iterdir())]
    hashed = []
    real = integrity.sha256
    monkeypatch.setattr(integrity, "sha256", lambda path: hashed.append(path.name) or real(path))
    record = json.loads(integrity.completion_record(3, files))
    assert record["index"] == 3
    assert record["files"] == {
        name: {"bytes": path.stat().st_size,
               "sha256": hashlib.sha256(path.read_bytes()).hexdigest()} for name, path in files}
    assert sorted(hashed) == ["copy.png", "im0.png", "im1.png"]  # im1E, im1L: im1's digest
