"""Hand-picked examples for the atomic writes of ``matcher.io.atomic``."""

from __future__ import annotations

import os

import pytest

from matcher.io import atomic
from matcher.io.atomic import atomic_write_bytes


def _files(root):
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())


def test_atomic_write_replaces_existing_file(tmp_path):
    target = tmp_path / "f.bin"
    target.write_bytes(b"old")
    atomic_write_bytes(target, b"new", fsync=False)
    assert target.read_bytes() == b"new" and _files(tmp_path) == ["f.bin"]


def test_atomic_write_failure_keeps_old_content_and_removes_temp(tmp_path, monkeypatch):
    target = tmp_path / "f.bin"
    target.write_bytes(b"old")

    def boom(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(atomic.os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        atomic_write_bytes(target, b"new")
    assert target.read_bytes() == b"old" and _files(tmp_path) == ["f.bin"]


def test_atomic_write_fsyncs_before_rename(tmp_path, monkeypatch):
    calls = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(atomic.os, "fsync", lambda fd: (calls.append("fsync"), real_fsync(fd)))
    monkeypatch.setattr(atomic.os, "replace", lambda a, b: (calls.append("replace"), real_replace(a, b)))
    atomic_write_bytes(tmp_path / "g", b"x")
    assert calls == ["fsync", "replace"]
    calls.clear()
    atomic_write_bytes(tmp_path / "g", b"y", fsync=False)
    assert calls == ["replace"]


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)],
                         ids=["umask-022", "umask-002", "umask-077"])
def test_atomic_write_gives_the_umask_mode_not_mkstemps_0600(tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        new = atomic_write_bytes(tmp_path / "new.bin", b"x", fsync=False)
        (tmp_path / "old.bin").write_bytes(b"old")
        replaced = atomic_write_bytes(tmp_path / "old.bin", b"y", fsync=False)
    finally:
        os.umask(old)
    # the mode a plain write gives: under umask 022 other users can read the dataset
    assert new.stat().st_mode & 0o777 == mode
    assert replaced.stat().st_mode & 0o777 == mode
