"""--format webdataset: shards read back by webdataset.WebDataset with the Middlebury files' bytes,
resume and extension give the shards of one uninterrupted run, options refused before any work."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from stereoforge.errors import DatasetError
from synth.dataset.config.parse import loads_config
from synth.dataset.run import read_manifest, run_dataset
from synth.dataset.storage.shards import FIELDS

CONFIG = """\
name = "shards"
seed = 7
count = 7

[rig]
width = 40
height = 30

[scene]
base = {choice = ["slanted_plane", "flying"]}
texture = "noise"
"""
SHARD = 30_000  # bytes: a 40 x 30 sample is some 25 KB of members, so 2 samples a shard


def _shards(root: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(root.glob("shard-*.tar"))}


@pytest.fixture(scope="module")
def pair(tmp_path_factory, renderer) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("shards")
    cfg = loads_config(CONFIG)
    run_dataset(cfg, out=root / "mb", progress=False)
    run_dataset(cfg, out=root / "wds", fmt="webdataset", shard_size=SHARD, progress=False)
    return root / "mb", root / "wds"


@pytest.mark.gl
# webdataset leaves its last shard's file open (a ResourceWarning when it is collected)
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_webdataset_reads_the_shards_with_the_middlebury_bytes(pair):
    import webdataset as wds

    mb, out = pair
    shards = sorted(out.glob("shard-*.tar"))
    assert len(shards) >= 2
    index = json.loads((out / "shards.json").read_text())["shards"]
    assert [s["name"] for s in index] == [p.name for p in shards]
    assert all(s["sealed"] for s in index[:-1]) and sum(s["count"] for s in index) == 7
    seen = []
    for sample in wds.WebDataset([str(p) for p in shards], shardshuffle=False, empty_check=False):
        key = sample["__key__"]
        seen.append(key)
        folder = mb / "MiddEval3" / "trainingF" / key
        expected = {field: (folder / source).read_bytes() for source, field in FIELDS
                    if (folder / source).is_file()}
        assert {k: v for k, v in sample.items() if not k.startswith("__")} == expected
    assert seen == [f"{i:06d}" for i in range(7)]
    assert read_manifest(out) == read_manifest(mb)
    assert not (out / ".staging").exists()
    for s in index[:-1]:  # a shard closes once it holds shard_size bytes of members
        assert s["bytes"] >= SHARD


@pytest.mark.gl
def test_extension_and_leftovers_of_a_killed_run_give_the_same_shards(pair, tmp_path):
    _, reference = pair
    cfg = loads_config(CONFIG)
    out = tmp_path / "wds"
    full = json.loads((reference / "shards.json").read_text())["shards"][0]["count"]
    # a smaller run ends on a short shard (one sample): written unsealed, so the extension
    # renders its sample again and refills it
    run_dataset(cfg, out=out, count=full + 1, fmt="webdataset", shard_size=SHARD, progress=False)
    smaller = json.loads((out / "shards.json").read_text())["shards"]
    assert [(s["count"], s["sealed"]) for s in smaller] == [(full, True), (1, False)]
    # what a run killed mid-way leaves: a shard being written, one renamed but not yet listed,
    # and a staged sample
    (out / ".shard-000009.tar.tmp-123").write_bytes(b"partial")
    (out / "shard-000007.tar").write_bytes(b"renamed, not listed")
    again = run_dataset(cfg, out=out, fmt="webdataset", shard_size=SHARD, progress=False)
    assert again.rendered + again.skipped == 7 and again.rendered >= 3
    assert _shards(out) == _shards(reference)
    assert (out / "shards.json").read_bytes() == (reference / "shards.json").read_bytes()
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [".lock"]
    done = run_dataset(cfg, out=out, fmt="webdataset", shard_size=SHARD, progress=False)
    assert (done.rendered, done.skipped) == (0, 7)
    with pytest.raises(DatasetError, match=r"shards of 30000 bytes, not 1000000000"):
        run_dataset(cfg, out=out, fmt="webdataset", progress=False)


def test_a_shard_size_without_shards_is_refused_before_any_work(tmp_path):
    from synth.cli import main

    cfg = loads_config(CONFIG)
    with pytest.raises(ValueError, match="shard_size applies to fmt='webdataset' only"):
        run_dataset(cfg, out=tmp_path / "x", fmt="kitti", shard_size=10, progress=False)
    result = CliRunner().invoke(main, ["dataset", "planes", "--out", str(tmp_path / "y"),
                                       "--shard-size", "1GB"])
    assert result.exit_code == 2 and "Error: shard_size applies to" in result.output
    bad = CliRunner().invoke(main, ["dataset", "planes", "--out", str(tmp_path / "z"),
                                    "--format", "webdataset", "--shard-size", "lots"])
    assert bad.exit_code == 2 and "Error: shard size: expected bytes" in bad.output
    assert not any(tmp_path.iterdir())


@pytest.mark.gl
def test_stereo_dataset_points_webdataset_to_its_reader(pair):
    from synth import StereoDataset

    with pytest.raises(DatasetError, match="webdataset.WebDataset"):
        StereoDataset(pair[1])


@pytest.mark.gl
def test_verify_checks_the_shards_and_the_staged_samples(pair, tmp_path):
    import shutil

    from synth.dataset.storage.integrity import verify_dataset

    out = tmp_path / "wds"
    shutil.copytree(pair[1], out)
    assert verify_dataset(out) == []
    shard = out / "shard-000001.tar"
    data = bytearray(shard.read_bytes())
    data[600] ^= 0xFF  # inside the first member's bytes: same size, other content
    shard.write_bytes(bytes(data))
    (out / "shard-000002.tar").unlink()
    assert verify_dataset(out, checksums=False) == [
        "shard-000002.tar: missing (listed in shards.json)"]
    assert verify_dataset(out) == [
        "shard-000001.tar: SHA-256 differs from shards.json (corrupt)",
        "shard-000002.tar: missing (listed in shards.json)"]


@pytest.mark.gl
@pytest.mark.filterwarnings("ignore::ResourceWarning")
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_gzip_float_maps_round_trip_losslessly(pair, tmp_path):
    """--disp-encoding pfm.gz: every .pfm member gzip-compressed, decompressed to the PFM bytes
    (by gzip and by webdataset's default decoder), smaller, and the same bytes on a rerun."""
    import gzip
    import tarfile

    import webdataset as wds

    from matcher.io import decode_pfm, read_pfm
    from synth.dataset.storage.integrity import verify_dataset

    mb, plain = pair
    cfg = loads_config(CONFIG)
    out = tmp_path / "gz"
    run_dataset(cfg, out=out, fmt="webdataset", shard_size=SHARD, disp_encoding="pfm.gz",
                progress=False)
    assert verify_dataset(out) == []
    assert json.loads((out / "dataset.json").read_text())["disp_encoding"] == "pfm.gz"
    assert "disp_encoding" not in json.loads((plain / "dataset.json").read_text())
    packed = unpacked = 0
    for shard in sorted(out.glob("shard-*.tar")):
        with tarfile.open(shard) as tar:
            for m in tar.getmembers():
                key, field = m.name.split(".", 1)
                data = tar.extractfile(m).read()
                folder = mb / "MiddEval3" / "trainingF" / key
                if field.endswith(".pfm.gz"):
                    source = {f: s for s, f in FIELDS}[field[:-3]]
                    original = (folder / source).read_bytes()
                    assert gzip.decompress(data) == original
                    packed, unpacked = packed + len(data), unpacked + len(original)
                else:
                    assert not field.endswith(".pfm")
    assert 0 < packed < unpacked
    decoded = next(iter(wds.WebDataset(str(out / "shard-000000.tar"), shardshuffle=False,
                                       empty_check=False).decode()))
    original = mb / "MiddEval3" / "trainingF" / decoded["__key__"] / "disp0GT.pfm"
    assert decoded["disp.pfm.gz"] == original.read_bytes()  # gunzipped by the default decoder
    np.testing.assert_array_equal(decode_pfm(decoded["disp.pfm.gz"]), read_pfm(original))
    again = tmp_path / "gz2"
    run_dataset(cfg, out=again, fmt="webdataset", shard_size=SHARD, disp_encoding="pfm.gz",
                progress=False)
    assert _shards(again) == _shards(out)
    with pytest.raises(DatasetError, match="encoded as pfm.gz, not pfm"):
        run_dataset(cfg, out=out, fmt="webdataset", shard_size=SHARD, progress=False)


def test_a_disp_encoding_without_shards_is_refused_before_any_work(tmp_path):
    from synth.cli import main

    with pytest.raises(ValueError, match="disp_encoding applies to fmt='webdataset' only"):
        run_dataset(loads_config(CONFIG), out=tmp_path / "x", disp_encoding="pfm.gz",
                    progress=False)
    result = CliRunner().invoke(main, ["dataset", "planes", "--out", str(tmp_path / "y"),
                                       "--disp-encoding", "pfm.gz"])
    assert result.exit_code == 2 and "Error: disp_encoding applies to" in result.output
    assert not any(tmp_path.iterdir())
