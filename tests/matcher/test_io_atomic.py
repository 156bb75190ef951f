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


def test_a_repeated_bytes_object_is_a_hard_link_to_its_first_file(tmp_path):
    im1 = b"right view"
    other = bytes(bytearray(im1))  # equal bytes but another object: written
    files = {tmp_path / "im1.png": im1, tmp_path / "im1E.png": im1, tmp_path / "x.png": other,
             tmp_path / "im1L.png": im1}
    written = atomic.write_all_atomic(files, fsync=False)
    assert written == list(files)  # in the given order
    assert all(p.read_bytes() == b"right view" for p in written)
    inode = (tmp_path / "im1.png").stat().st_ino
    assert [p.stat().st_ino == inode for p in written] == [True, True, False, True]
    assert (tmp_path / "im1.png").stat().st_nlink == 3
    assert _files(tmp_path) == ["im1.png", "im1E.png", "im1L.png", "x.png"]  # no temporaries
    # written again over itself (the links already there, a rename between links is a no-op)
    atomic.write_all_atomic({tmp_path / "im1.png": im1, tmp_path / "im1E.png": im1}, fsync=False)
    assert (tmp_path / "im1E.png").read_bytes() == im1 and _files(tmp_path) == [
        "im1.png", "im1E.png", "im1L.png", "x.png"]


def test_a_repeat_is_written_where_the_file_system_refuses_hard_links(tmp_path, monkeypatch):
    def refuse(src, dst):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(atomic.os, "link", refuse)
    data = b"right view"
    atomic.write_all_atomic({tmp_path / "a": data, tmp_path / "b": data}, fsync=False)
    assert (tmp_path / "b").read_bytes() == data
    assert (tmp_path / "a").stat().st_ino != (tmp_path / "b").stat().st_ino
    assert _files(tmp_path) == ["a", "b"]


def test_a_failed_rename_of_the_link_leaves_no_temporary(tmp_path, monkeypatch):
    data = b"right view"
    real_replace = os.replace

    def fail_on_link(src, dst):
        if str(dst).endswith("b"):
            raise OSError("disk full")
        return real_replace(src, dst)

    monkeypatch.setattr(atomic.os, "replace", fail_on_link)
    with pytest.raises(OSError, match="disk full"):
        atomic.write_all_atomic({tmp_path / "a": data, tmp_path / "b": data}, fsync=False)
    assert _files(tmp_path) == ["a"]


def test_a_repeat_in_another_directory_is_written(tmp_path):
    (tmp_path / "sub").mkdir()
    data = b"right view"
    atomic.write_all_atomic({tmp_path / "a": data, tmp_path / "sub" / "b": data}, fsync=False)
    assert (tmp_path / "a").stat().st_ino != (tmp_path / "sub" / "b").stat().st_ino
