"""The error boundary: every subcommand, fed bad input or a bad environment, prints one
``Error:`` line (no traceback), exits 2 (usage) or 1 (environment) and leaves no file behind."""

from __future__ import annotations

import errno
import os
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from matcher.io import encode_pfm, encode_png, read_pfm, write_pfm
from synth.cli import main
from synth.cli.errors import describe_error

_BIG = "1" + "0" * 400
_DEEP = "[" * 50_000


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


_HUGE_PNG = (b"\x89PNG\r\n\x1a\n"
             + _chunk(b"IHDR", struct.pack(">IIBBBBB", 40000, 40000, 8, 0, 0, 0, 0))
             + _chunk(b"IDAT", zlib.compress(b"\0" * 100)) + _chunk(b"IEND", b""))
_PLANE = '{"name": "x", "objects": [{"kind": "plane", "pose": {"translation": [0, 0, 2]}, "size": [%s, 1]}]}'

#: Files every case may name (made in the test's directory before the command runs).
_INPUTS: dict[str, bytes] = {
    "wrong-type.json": b'{"name": "x", "objects": 5}',
    "deep.json": _DEEP.encode(),
    "deep.toml": ("a = " + _DEEP).encode(),
    "latin1.toml": b'name = "\xff"\n',
    "latin1.json": b'{"name": "\xff"}',
    "bigint.json": (_PLANE % _BIG).encode(),
    "bigint.toml": f"[scene]\nfrequency_px = {_BIG}\n".encode(),
    "huge-plane.json": (_PLANE % "1e300").encode(),
    "huge.png": _HUGE_PNG,
    "garbage.png": b"not a png",
    "truncated.pfm": b"Pf\n4 4\n-1\n\x00\x00",
    "gray.png": encode_png(np.full((16, 24), 128, np.uint8)),
    "flat.pfm": encode_pfm(np.full((16, 24), 5.0, np.float32)),
    # mask0nocc.png drawn in colour: green where visible (its red channel is 0 everywhere)
    "colour-mask.png": encode_png(np.dstack([np.zeros((16, 24), np.uint8),
                                             np.full((16, 24), 255, np.uint8),
                                             np.zeros((16, 24), np.uint8)])),
    "a-file": b"",
    "a-folder/notes.txt": b"no stereo here",
    "list/dataset.json": b"[]",
    "empty/dataset.json": b"{}",
    "golden-list/manifest.json": b"[]",
    "scene-dir/scene.json": b"{}",  # a render's --out folder, given as the scene
    "configs.toml/planes.toml": b"",  # a folder of configurations, named like one
    # a UTF-8 byte-order mark (Windows editors) is dropped: the error is the one on line 4
    "bom-bad.toml": b'\xef\xbb\xbfname = "bom"\n\n[scene]\nfrequency_px = "high"\n',
    "bom-study.toml": b'\xef\xbb\xbfname = "bom"\n\n[match]\nwindows = [5, 8]\n',
}

# (name, arguments, exit status, words the Error line must hold)
CASES = [
    ("presets: unknown option", ["presets", "--bogus"], 2, ["--bogus"]),
    ("render: objects of the wrong type", ["render", "wrong-type.json", "--out", "o"], 2,
     ["wrong-type.json", "scene.objects", "array"]),
    ("render: JSON nested 50,000 deep", ["render", "deep.json", "--out", "o"], 2,
     ["deep.json", "nested too deeply"]),
    ("render: TOML nested 50,000 deep", ["render", "deep.toml", "--out", "o"], 2,
     ["deep.toml", "nested too deeply"]),
    ("render: scene not UTF-8", ["render", "latin1.json", "--out", "o"], 2,
     ["latin1.json", "utf-8", "0xff"]),
    ("render: integer beyond the float range", ["render", "bigint.json", "--out", "o"], 2,
     ["bigint.json", "size", "finite number"]),
    ("render: a plane of 1e300 m", ["render", "huge-plane.json", "--out", "o"], 2,
     ["MAX_EXTENT", "1e+300"]),
    ("render: missing scene file", ["render", "nowhere.toml", "--out", "o"], 2, ["nowhere.toml"]),
    ("render: a directory as the scene", ["render", "scene-dir", "--out", "o"], 2,
     ["scene file scene-dir is a directory (holding scene.json)", ".toml or .json scene file"]),
    ("render: a directory named .toml as the scene", ["render", "configs.toml", "--out", "o"], 2,
     ["scene file configs.toml is a directory (holding planes.toml)"]),
    ("render: --out under a file", ["render", "fronto_plane", "--out", "a-file/o"], 1,
     ["a-file", "not a directory"]),
    ("render: dataset.json is []", ["render", "--from-manifest", "list", "0", "--out", "o"], 2,
     ["list/dataset.json", "expected a JSON object"]),
    ("render: dataset.json is {}", ["render", "--from-manifest", "empty", "0", "--out", "o"], 2,
     ["empty/dataset.json", "'config' is missing"]),
    ("render: negative baseline", ["render", "fronto_plane", "--baseline", "-1", "--out", "o"], 2,
     ["baseline"]),
    ("dataset: config nested 50,000 deep", ["dataset", "deep.toml", "--out", "o"], 2,
     ["deep.toml", "nested too deeply"]),
    ("dataset: config not UTF-8", ["dataset", "latin1.toml", "--out", "o"], 2,
     ["latin1.toml", "utf-8"]),
    ("dataset: integer beyond the float range", ["dataset", "bigint.toml", "--out", "o"], 2,
     ["bigint.toml:2", "scene.frequency_px"]),
    ("dataset: unknown config", ["dataset", "nowhere", "--out", "o"], 2, ["nowhere", "planes"]),
    ("dataset: a directory as the config", ["dataset", "configs.toml", "--out", "o"], 2,
     ["dataset config configs.toml is a directory (holding planes.toml)", "pass a .toml file"]),
    ("dataset: a bad value after a byte-order mark", ["dataset", "bom-bad.toml", "--out", "o"],
     2, ["bom-bad.toml:4: scene.frequency_px"]),
    ("dataset: --out under a file", ["dataset", "planes", "--out", "a-file/o"], 1,
     ["a-file", "not a directory"]),
    ("dataset: --out holds a broken dataset.json", ["dataset", "planes", "--out", "list"], 2,
     ["list/dataset.json", "expected a JSON object"]),
    ("demo: --out under a file", ["demo", "--out", "a-file/o"], 1, ["a-file", "not a directory"]),
    ("match: PNG announcing 40000x40000", ["match", "huge.png", "huge.png", "--out", "d.pfm"], 2,
     ["huge.png", "40000x40000"]),
    ("match: not an image", ["match", "garbage.png", "garbage.png", "--out", "d.pfm"], 2,
     ["garbage.png", "decode"]),
    ("match: missing image", ["match", "nowhere.png", "gray.png", "--out", "d.pfm"], 2,
     ["nowhere.png"]),
    ("match: --out not .pfm", ["match", "gray.png", "gray.png", "--out", "d.png"], 2, [".pfm"]),
    ("match: even window", ["match", "gray.png", "gray.png", "--window", "4", "--out", "d.pfm"],
     2, ["window"]),
    ("match: --out under a file", ["match", "gray.png", "gray.png", "--max-disp", "8",
                                   "--window", "3", "--out", "a-file/d.pfm"], 1, ["a-file/d.pfm"]),
    ("eval: PNG announcing 40000x40000", ["eval", "huge.png", "huge.png", "--gt-divisor", "1",
                                          "--disp-divisor", "1"], 2, ["huge.png", "40000x40000"]),
    ("eval: truncated PFM", ["eval", "truncated.pfm", "truncated.pfm"], 2,
     ["truncated.pfm", "too short"]),
    ("eval: missing file", ["eval", "nowhere.pfm", "truncated.pfm"], 2, ["nowhere.pfm"]),
    ("eval: a colour --mask", ["eval", "flat.pfm", "flat.pfm", "--mask", "colour-mask.png"], 2,
     ["colour-mask.png: mask must be one channel (grey) PNG, got 3 channels", "255 visible"]),
    ("eval --benchmark: a colour --mask", ["eval", "flat.pfm", "flat.pfm", "--benchmark", "all",
                                           "--mask", "colour-mask.png"], 2,
     ["mask must be one channel (grey) PNG, got 3 channels"]),
    ("eval --benchmark kitti: a colour --obj-map", ["eval", "flat.pfm", "flat.pfm", "--benchmark",
                                                    "kitti", "--obj-map", "colour-mask.png"], 2,
     ["colour-mask.png: obj_map must be one channel (grey) PNG, got 3 channels"]),
    ("paper: no data", ["paper", "--data", "nowhere", "--out", "o"], 2, ["nowhere", "--data"]),
    ("study: config nested 50,000 deep", ["study", "deep.toml", "--out", "o"], 2,
     ["deep.toml", "nested too deeply"]),
    ("study: config not UTF-8", ["study", "latin1.toml", "--out", "o"], 2, ["latin1.toml", "utf-8"]),
    ("study: unknown config", ["study", "nowhere", "--out", "o"], 2, ["nowhere"]),
    ("study: a bad value after a byte-order mark", ["study", "bom-study.toml", "--out", "o"], 2,
     ["bom-study.toml:4: match.windows[1]"]),
    ("study: a directory as the config", ["study", "configs.toml", "--out", "o"], 2,
     ["study config configs.toml is a directory (holding planes.toml)", "pass a .toml file"]),
    ("golden check: manifest is []", ["golden", "check", "--root", "golden-list", "--no-render"],
     2, ["golden-list/manifest.json", "expected a JSON object"]),
    ("golden update: unknown backend", ["golden", "update", "--backend", "bogus"], 2, ["bogus"]),
    ("bench render: bad size", ["bench", "render", "--sizes", "10xfoo", "--out", "o"], 2,
     ["10xfoo", "WIDTHxHEIGHT"]),
    ("bench render: bad threads", ["bench", "render", "--threads", "x", "--out", "o"], 2,
     ["--threads"]),
    ("bench match: zero repeats", ["bench", "match", "--repeats", "0", "--out", "o"], 2,
     ["--repeats"]),
    ("bench paper: unknown option", ["bench", "paper", "--bogus"], 2, ["--bogus"]),
    ("bench dataset: unknown config", ["bench", "dataset", "--configs", "nowhere", "--out", "o"],
     2, ["nowhere"]),
    ("bench dataset: zero workers", ["bench", "dataset", "--workers", "0", "--out", "o"], 2,
     ["--workers"]),
    ("bench dataset: unknown image deflate", ["bench", "dataset", "--image-deflate", "isal,zstd",
                                              "--out", "o"], 2, ["--image-deflate", "'isal,zstd'"]),
    ("bench realism: no third/ under --data", ["bench", "realism", "--data", "nowhere", "--out",
                                                "o"], 2, ["--data", "third/"]),
    ("bench validate: bad workers", ["bench", "validate", "--workers", "x", "--out", "o"], 2,
     ["--workers"]),
    ("bench transfer: bad seeds", ["bench", "transfer", "--seeds", "1,x", "--out", "o"], 2,
     ["--seeds", "'1,x'"]),
    ("bench transfer: two budgets", ["bench", "transfer", "--minutes", "1", "--steps", "5",
                                     "--out", "o"], 2, ["--minutes and --steps", "give one"]),
    ("bench transfer: unknown config", ["bench", "transfer", "--configs", "nowhere", "--out",
                                        "o"], 2, ["nowhere", "one of the examples"]),
    ("train: a folder without ground truth", ["train", "a-folder", "--out", "m.pt", "--steps",
                                              "1"], 2, ["a-folder", "no dataset.json",
                                                        "disp0GT.pfm"]),
    ("validate: a MATCHER that does not resolve", ["validate", "sad", "--out", "o"], 2,
     ["matcher 'sad'", "tried a built-in method"]),
    ("validate: unknown axis", ["validate", "ct:9", "--out", "o", "--axes", "nois"], 2,
     ["--axes", "nois"]),
    ("eval-dataset: a folder without samples", ["eval-dataset", "empty", "--matcher", "ct"], 2,
     ["no samples", "--keep-pairs"]),
    ("eval-dataset: a MATCHER that does not resolve",
     ["eval-dataset", "empty", "--matcher", "py:nowhere_xyz:f"], 2, ["nowhere_xyz"]),
]


def _listing(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def _invoke(args, cwd: Path):
    old = Path.cwd()
    os.chdir(cwd)
    try:
        return CliRunner().invoke(main, [str(a) for a in args])
    finally:
        os.chdir(old)


def _check_one_error_line(result, status: int, words) -> str:
    output = result.output
    assert "Traceback" not in output, output
    errors = [line for line in output.splitlines() if line.startswith("Error:")]
    assert len(errors) == 1, output
    assert result.exit_code == status, output
    assert not isinstance(result.exception, Exception) or isinstance(result.exception, SystemExit), \
        result.exception
    for word in words:
        assert word.lower() in errors[0].lower(), (word, errors[0])
    return errors[0]


@pytest.mark.parametrize(("name", "args", "status", "words"), CASES, ids=[c[0] for c in CASES])
def test_every_subcommand_reports_bad_input_in_one_line(tmp_path, name, args, status, words):
    for rel, data in _INPUTS.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(data)
    before = _listing(tmp_path)
    result = _invoke(args, tmp_path)
    _check_one_error_line(result, status, words)
    left = _listing(tmp_path) - before
    if name == "dataset: --out holds a broken dataset.json":
        left.discard("list/.lock")  # run_dataset locks the directory before it reads it
    assert not left, f"files left behind: {sorted(left)}"


def test_every_subcommand_has_a_case():
    covered = {tuple(c[1][:2]) if c[1][0] in ("golden", "bench") else (c[1][0],) for c in CASES}
    commands = set()
    for name, command in main.commands.items():
        sub = getattr(command, "commands", None)
        commands |= {(name, s) for s in sub} if sub else {(name,)}
    assert commands <= covered, commands - covered


@pytest.mark.gl
def test_a_size_above_the_gl_limit_names_the_limit(tmp_path, renderer):
    limit = renderer._passes.limits.renderbuffer
    result = _invoke(["render", "fronto_plane", "--width", str(limit + 1), "--height", "16",
                      "--out", "o"], tmp_path)
    line = _check_one_error_line(result, 2, ["width", str(limit), "GL_MAX_RENDERBUFFER_SIZE"])
    assert "apt-get" not in line
    assert _listing(tmp_path) == set()


def test_debug_shows_the_traceback(tmp_path):
    (tmp_path / "s.json").write_text('{"name": "x", "objects": 5}')
    # the installed console script beside this interpreter (a venv's bin/ need not be on PATH)
    tool = str(Path(sys.executable).with_name("stereoforge"))
    plain = subprocess.run([tool, "render", "s.json", "--out", "o"], cwd=tmp_path,
                           capture_output=True, text=True)
    debug = subprocess.run([tool, "--debug", "render", "s.json", "--out", "o"],
                           cwd=tmp_path, capture_output=True, text=True)
    assert plain.returncode == 2 and "Traceback" not in plain.stderr
    assert plain.stderr.strip().splitlines() == [
        "Error: s.json: scene.objects: expected an array of tables, got int 5"]
    assert debug.returncode == 1 and "Traceback" in debug.stderr
    assert "ParameterTypeError" in debug.stderr


@pytest.mark.parametrize(("exc", "status", "words"), [
    (OSError(errno.ENOSPC, "No space left on device", "o/im0.png"), 1, ["o/im0.png", "free"]),
    (OSError(errno.EROFS, "Read-only file system", "o"), 1, ["read-only", "another --out"]),
    (PermissionError(errno.EACCES, "Permission denied", "o"), 1, ["permission denied"]),
    (FileNotFoundError(errno.ENOENT, "No such file or directory", "x.png"), 2, ["x.png"]),
    (IsADirectoryError(errno.EISDIR, "Is a directory", "x.png"), 2, ["x.png", "give a file"]),
    (MemoryError(), 1, ["out of memory"]),
    (KeyError("k"), 1, ["unexpected KeyError", "--debug"]),
])
def test_describe_error_maps_environment_errors(exc, status, words):
    message, code = describe_error(exc)
    assert code == status
    for word in words:
        assert word.lower() in message.lower()


_BOM = b"\xef\xbb\xbf"


@pytest.mark.gl
def test_files_with_a_utf8_byte_order_mark_are_read(tmp_path, renderer):
    from scenes import dumps_toml, get_preset

    (tmp_path / "scene.toml").write_bytes(_BOM + dumps_toml(get_preset("fronto_plane")).encode())
    (tmp_path / "cfg.toml").write_bytes(
        _BOM + b'name = "bom"\ncount = 1\n\n[rig]\nwidth = 16\nheight = 12\n')
    render = _invoke(["render", "scene.toml", "--width", "16", "--height", "12", "--out", "r"],
                     tmp_path)
    assert render.exit_code == 0 and "Error" not in render.output, render.output
    dataset = _invoke(["dataset", "cfg.toml", "--out", "d"], tmp_path)
    assert dataset.exit_code == 0 and "1 rendered" in dataset.output, dataset.output


# --------------------------------------------------------------------------- disk full
@pytest.fixture
def small_disk(tmp_path, monkeypatch):
    """A 200 KB tmpfs (root and mount(8) available), else ENOSPC from ``os.replace`` of a file."""
    mount = tmp_path / "disk"
    mount.mkdir()
    ok = os.geteuid() == 0 and subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=200k", "tmpfs", str(mount)],
        capture_output=True).returncode == 0
    if not ok:
        real = os.replace

        def full(src, dst, *a, **k):
            if Path(src).is_file():
                raise OSError(errno.ENOSPC, "No space left on device")
            return real(src, dst, *a, **k)

        monkeypatch.setattr(os, "replace", full)
    try:
        yield mount
    finally:
        if ok:
            subprocess.run(["umount", str(mount)], check=True)


@pytest.mark.gl
def test_render_on_a_full_disk_leaves_nothing_and_a_rerun_works(small_disk, renderer):
    result = _invoke(["render", "fronto_plane", "--width", "640", "--height", "480",
                      "--out", "o"], small_disk)
    _check_one_error_line(result, 1, ["o/", "no space left", "free some space"])
    assert _listing(small_disk) == set()
    again = _invoke(["render", "fronto_plane", "--width", "32", "--height", "24", "--out", "o"],
                    small_disk)
    if again.exit_code == 0:  # the real tmpfs has room for a small pair
        assert sorted(p.name for p in (small_disk / "o").iterdir())[:2] == ["calib.txt",
                                                                           "disp0GT.pfm"]


def test_match_on_a_full_disk_keeps_the_previous_file(small_disk, tmp_path):
    previous = small_disk / "d.pfm"
    write_pfm(previous, np.full((2, 2), 7.0, np.float32))
    big = small_disk / "filler"
    if os.statvfs(small_disk).f_bavail:  # the real tmpfs: fill it but for a few blocks
        with open(big, "wb") as f:
            try:
                f.write(b"\0" * (os.statvfs(small_disk).f_bavail - 2) * os.statvfs(small_disk).f_frsize)
            except OSError:
                pass
    image = tmp_path / "img.png"
    rng = np.random.default_rng(0)
    image.write_bytes(encode_png(rng.integers(0, 256, (120, 160), dtype=np.uint8)))
    before = _listing(small_disk)
    result = _invoke(["match", str(image), str(image), "--window", "3", "--max-disp", "8",
                      "--out", str(previous)], tmp_path)
    _check_one_error_line(result, 1, ["d.pfm", "no space left"])
    assert _listing(small_disk) == before  # no temporary file left
    assert (read_pfm(previous) == 7.0).all()  # the previous good file is intact


# --------------------------------------------------------------------------- render --from-manifest
_TINY = """\
name = "tiny"
seed = 5
count = 2
[rig]
width = 48
height = 32
[scene]
base = {choice = ["fronto_plane", "boxes"]}
"""


@pytest.fixture
def tiny_dataset(tmp_path, renderer) -> Path:
    from synth.dataset.run import run_dataset

    config = tmp_path / "tiny.toml"
    config.write_text(_TINY)
    run_dataset(config, out=tmp_path / "ds", count=2, progress=False)
    return tmp_path / "ds"


def _disk_full_at(monkeypatch, name: str) -> list[str]:
    """Make the first atomic write of a file ``name`` fail with ENOSPC (its rename, wherever it
    is written); returns the names renamed before, the fault's included."""
    real, staged = os.replace, []

    def replace(src, dst, *a, **k):
        staged.append(Path(dst).name)
        if Path(dst).name == name and staged.count(name) == 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(src, dst, *a, **k)

    monkeypatch.setattr(os, "replace", replace)
    return staged


@pytest.mark.gl
@pytest.mark.parametrize("previous", [None, 1])
def test_render_from_manifest_on_a_full_disk_keeps_the_previous_output(
        tiny_dataset, tmp_path, monkeypatch, previous):
    out = tmp_path / "one"
    args = ["render", "--from-manifest", tiny_dataset, 0, "--out", out]
    if previous is not None:  # a previous good output (another sample), overwritten on purpose
        assert _invoke(["render", "--from-manifest", tiny_dataset, previous, "--out", out],
                       tmp_path).exit_code == 0
        args.append("--overwrite")
    before = {str(p.relative_to(tmp_path)): p.read_bytes() for p in tmp_path.rglob("*")
              if p.is_file()}
    staged = _disk_full_at(monkeypatch, "disp0GT.pfm")
    result = _invoke(args, tmp_path)
    _check_one_error_line(result, 1, ["one/disp0GT.pfm", "no space left", "free some space"])
    assert len(staged) > 1  # the fault came after other files of the sample were written
    after = {str(p.relative_to(tmp_path)): p.read_bytes() for p in tmp_path.rglob("*")
             if p.is_file()}
    assert after == before  # nothing half-written, no temporary folder, the previous output intact
    monkeypatch.undo()
    again = _invoke(args, tmp_path)  # a rerun into the same --out works
    assert again.exit_code == 0, again.output
    sample = tiny_dataset / "MiddEval3" / "trainingF" / "000000"
    expected = {p.name: p.read_bytes() for p in sample.iterdir() if p.name != "files.json"}
    assert {name: (out / name).read_bytes() for name in expected} == expected
    assert sorted(p.name for p in out.iterdir()) == sorted(expected)
