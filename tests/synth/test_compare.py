"""synth.dataset.compare and `stereoforge dataset --compare A B`: each kind of difference."""

from __future__ import annotations

import gzip
import io
import json
import shutil
import tarfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from matcher.io import encode_pfm, encode_png
from synth._util.json_records import json_bytes
from synth.cli import main
from synth.dataset.compare import Difference, compare_datasets, same_content, summarize
from synth.dataset.storage.shards import sha256

_MASK = np.full((6, 8), 255, np.uint8)
_MASK[2:4, 3:5] = 128
_DISP = np.linspace(1.0, 4.0, 48, dtype=np.float32).reshape(6, 8)
_DISP[0, 0] = np.inf


def _record(root: Path, names: list[str]) -> bytes:
    return json_bytes({"files": {n: {"bytes": (root / n).stat().st_size,
                                     "sha256": sha256(root / n)} for n in names}, "index": 0})


def _dataset(root: Path, *, mask: np.ndarray = _MASK, deflate: str | None = None,
             disp: np.ndarray = _DISP, meta: dict | None = None) -> Path:
    sample = root / "MiddEval3" / "trainingF" / "000000"
    sample.mkdir(parents=True)
    (sample / "mask0nocc.png").write_bytes(encode_png(mask, deflate=deflate))
    (sample / "disp0GT.pfm").write_bytes(encode_pfm(disp))
    (sample / "calib.txt").write_text("cam0=[60 0 32; 0 60 24; 0 0 1]\nndisp=8\n")
    (sample / "sample.json").write_bytes(json_bytes(meta or {"index": 0, "seed": 7}))
    (root / "records").mkdir()
    names = sorted(p.relative_to(root).as_posix() for p in sample.iterdir())
    (root / "records" / "000000.json").write_bytes(_record(root, names))
    return root


def _kinds(differences: list[Difference]) -> dict[str, str]:
    return {d.path: d.kind for d in differences}


def test_identical_folders_have_no_difference(tmp_path):
    a, b = _dataset(tmp_path / "a"), _dataset(tmp_path / "b")
    assert compare_datasets(a, b) == []
    assert summarize([]) == "byte-identical" and same_content([])


def test_a_png_encoded_by_another_deflate_is_the_same_content(tmp_path):
    a, b = _dataset(tmp_path / "a"), _dataset(tmp_path / "b", deflate="zlib")
    found = compare_datasets(a, b)
    mask = "MiddEval3/trainingF/000000/mask0nocc.png"
    assert _kinds(found) == {mask: "encoding", "records/000000.json": "hashes"}
    record = next(d for d in found if d.kind == "hashes")
    assert record.files == (mask,) and mask in record.detail
    assert "the same pixels" in str(next(d for d in found if d.kind == "encoding"))
    assert same_content(found)
    assert summarize(found) == ("the same content; 1 file(s) encoded differently, 1 record(s) "
                                "listing their hashes")


def test_changed_pixels_are_counted_and_located(tmp_path):
    changed = _MASK.copy()
    changed[4, 6] = 0
    changed[5, 1] = 128
    a, b = _dataset(tmp_path / "a"), _dataset(tmp_path / "b", mask=changed)
    found = compare_datasets(a, b)
    mask = next(d for d in found if d.path.endswith("mask0nocc.png"))
    assert mask.kind == "content"
    assert mask.detail == ("2 of 48 pixels differ, largest |difference| 255; first at row 4, "
                           "column 6: 255 vs 0")
    # the record's hashes differ because a file's content does: content too
    assert _kinds(found)["records/000000.json"] == "content"
    assert not same_content(found)
    assert summarize(found) == "different: 2 file(s) differ in content"


def test_changed_disparities_name_the_largest_difference(tmp_path):
    changed = _DISP.copy()
    changed[3, 2] += 0.25
    changed[5, 7] = np.inf  # a value that became unknown
    found = compare_datasets(_dataset(tmp_path / "a"), _dataset(tmp_path / "b", disp=changed))
    disp = next(d for d in found if d.path.endswith("disp0GT.pfm"))
    assert disp.kind == "content"
    assert disp.detail.startswith("2 of 48 values differ, largest |difference| 0.25; first at "
                                  "row 3, column 2:")


def test_json_values_versus_formatting(tmp_path):
    a = _dataset(tmp_path / "a")
    b = tmp_path / "b"
    shutil.copytree(a, b)
    (b / "MiddEval3/trainingF/000000/sample.json").write_text('{"seed": 7, "index": 0}')
    found = compare_datasets(a, b)
    assert [(d.path, d.kind, d.detail) for d in found] == [
        ("MiddEval3/trainingF/000000/sample.json", "encoding",
         "the same JSON values, formatted differently")]
    (b / "MiddEval3/trainingF/000000/sample.json").write_text('{"seed": 8, "index": 0}')
    sample = next(d for d in compare_datasets(a, b) if d.path.endswith("sample.json"))
    assert (sample.kind, sample.detail) == ("content", "1 JSON value(s) differ: seed")
    # other JSON values though equal in Python (7.0 for 7, false for 0), and a new empty list
    for text in ('{"seed": 7.0, "index": 0}', '{"seed": 7, "index": false}',
                 '{"seed": 7, "index": 0, "x": []}'):
        (b / "MiddEval3/trainingF/000000/sample.json").write_text(text)
        sample = next(d for d in compare_datasets(a, b) if d.path.endswith("sample.json"))
        assert sample.kind == "content", text


def test_files_on_one_side_only(tmp_path):
    a, b = _dataset(tmp_path / "a"), _dataset(tmp_path / "b")
    (a / "extra.txt").write_text("x")
    (b / "MiddEval3/trainingF/000000/calib.txt").unlink()
    found = compare_datasets(a, b)
    assert _kinds(found) == {"MiddEval3/trainingF/000000/calib.txt": "only_a",
                             "extra.txt": "only_a"}
    assert summarize(compare_datasets(b, a)) == "different: 2 only in B"


def test_text_files_name_their_first_differing_line(tmp_path):
    a, b = _dataset(tmp_path / "a"), _dataset(tmp_path / "b")
    (b / "MiddEval3/trainingF/000000/calib.txt").write_text(
        "cam0=[60 0 32; 0 60 24; 0 0 1]\nndisp=9\n")
    calib = next(d for d in compare_datasets(a, b) if d.path.endswith("calib.txt"))
    assert calib.detail == "line 2 differs: b'ndisp=8' vs b'ndisp=9'"


def _shard(path: Path, members: dict[str, bytes]) -> None:
    with tarfile.open(path, "w") as tar:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))


def test_tar_shards_are_compared_member_by_member(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    for root, deflate in ((a, None), (b, "zlib")):
        root.mkdir()
        members = {"000000.mask0nocc.png": encode_png(_MASK, deflate=deflate),
                   "000000.disp0GT.pfm.gz": gzip.compress(encode_pfm(_DISP))}
        _shard(root / "shard-000000.tar", members)
        (root / "shards.json").write_bytes(json_bytes({"shards": [
            {"name": "shard-000000.tar", "bytes": (root / "shard-000000.tar").stat().st_size,
             "sha256": sha256(root / "shard-000000.tar")}]}))
    found = compare_datasets(a, b)
    assert _kinds(found) == {"shard-000000.tar": "encoding", "shards.json": "hashes"}
    assert same_content(found)
    changed = _MASK.copy()
    changed[0, 0] = 0
    _shard(b / "shard-000000.tar", {"000000.mask0nocc.png": encode_png(changed),
                                    "000000.disp0GT.pfm.gz": gzip.compress(encode_pfm(_DISP),
                                                                           mtime=1)})
    found = compare_datasets(a, b)
    assert _kinds(found) == {"shard-000000.tar/000000.mask0nocc.png": "content",
                             "shard-000000.tar/000000.disp0GT.pfm.gz": "encoding",
                             "shards.json": "content"}


def test_an_undecodable_file_is_a_content_difference(tmp_path):
    a, b = _dataset(tmp_path / "a"), _dataset(tmp_path / "b")
    (b / "MiddEval3/trainingF/000000/mask0nocc.png").write_bytes(b"\x89PNG broken")
    mask = next(d for d in compare_datasets(a, b) if d.path.endswith("mask0nocc.png"))
    assert mask.kind == "content" and "not decodable as .png" in mask.detail


def test_fsspec_urls(tmp_path):
    pytest.importorskip("fsspec", reason="fsspec is the 'storage' extra (installed with 'test')")
    import fsspec

    a = _dataset(tmp_path / "a")
    fs = fsspec.filesystem("memory")
    for p in a.rglob("*"):
        if p.is_file():
            fs.pipe_file(f"/compare-test/{p.relative_to(a).as_posix()}", p.read_bytes())
    assert compare_datasets(a, "memory://compare-test") == []
    fs.pipe_file("/compare-test/MiddEval3/trainingF/000000/calib.txt", b"ndisp=8\n")
    assert _kinds(compare_datasets(a, "memory://compare-test")) == {
        "MiddEval3/trainingF/000000/calib.txt": "content"}
    fs.rm("/compare-test", recursive=True)


def test_the_command_line(tmp_path):
    a, b = _dataset(tmp_path / "a"), _dataset(tmp_path / "b", deflate="zlib")
    run = CliRunner().invoke(main, ["dataset", "--compare", str(a), str(b)])
    assert run.exit_code == 0, run.output
    lines = run.output.splitlines()
    assert lines[0].startswith("encoding MiddEval3/trainingF/000000/mask0nocc.png: the same pixels")
    assert lines[-1] == f"{a} vs {b}: the same content; 1 file(s) encoded differently, 1 " \
                        "record(s) listing their hashes"
    assert CliRunner().invoke(main, ["dataset", "--compare", str(a), str(b), "--bytes"]
                              ).exit_code == 1
    assert CliRunner().invoke(main, ["dataset", "--compare", str(a), str(a), "--bytes"]
                              ).exit_code == 0
    (b / "extra.txt").write_text("x")
    assert CliRunner().invoke(main, ["dataset", "--compare", str(a), str(b)]).exit_code == 1


@pytest.mark.parametrize("args, message", [
    (["--compare", "{a}", "{missing}"], "Invalid value for --compare: B: "),
    (["--bytes", "--verify", "{a}"], "--bytes applies to --compare A B only"),
    (["planes", "--compare", "{a}", "{a}"], "--compare A B compares two existing datasets"),
    (["--compare", "{a}", "{a}", "--indices", "0:1"], "--indices chooses the samples"),
])
def test_bad_command_lines_get_one_error_line(tmp_path, args, message):
    a = _dataset(tmp_path / "a")
    args = [x.format(a=a, missing=tmp_path / "missing") for x in args]
    run = CliRunner().invoke(main, ["dataset", *args])
    errors = [line for line in run.output.splitlines() if line.startswith("Error:")]
    assert run.exit_code == 2 and len(errors) == 1 and message in errors[0], run.output
    assert "Traceback" not in run.output
