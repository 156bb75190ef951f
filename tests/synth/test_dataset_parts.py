"""One dataset split over several drivers (``indices``, ``--indices START:STOP``): parts on
disjoint ranges write one output at once, a whole run then writes the manifest; the result is
byte for byte one whole run's."""

from __future__ import annotations

import subprocess
import sys
import threading
from importlib import resources
from pathlib import Path

import pytest
from click.testing import CliRunner

from stereoforge.errors import DatasetError, ParameterError, ParameterTypeError
from synth.cli import main
from synth.dataset.config.parse import loads_config
from synth.dataset.storage.integrity import verify_dataset
from synth.dataset.parts import RunLock
from synth.dataset.run import read_manifest, run_dataset

# the shipped `planes` example at a tiny size
CONFIG = (resources.files("synth.dataset") / "configs" / "planes.toml").read_text().replace(
    "width = 640\nheight = 480", "width = 40\nheight = 30")
COUNT = 6
SCENES = "MiddEval3/trainingF"


def _tree(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file()}


def _memory(prefix: str) -> dict[str, bytes]:
    import fsspec

    fs = fsspec.filesystem("memory")
    return {f.removeprefix(f"/{prefix}/"): bytes(fs.cat_file(f)) for f in fs.find(f"/{prefix}")}


def _assert_same(got: dict[str, bytes], want: dict[str, bytes]) -> None:
    assert sorted(got) == sorted(want)
    assert [k for k in want if got[k] != want[k]] == []


@pytest.fixture(scope="module")
def config_file(tmp_path_factory) -> Path:
    assert "width = 40\nheight = 30" in CONFIG  # not the shipped 640 x 480
    path = tmp_path_factory.mktemp("cfg") / "planes-40x30.toml"
    path.write_text(CONFIG)
    return path


@pytest.fixture(scope="module")
def whole(config_file, tmp_path_factory, renderer) -> Path:
    """One whole run of COUNT samples: what every split must equal."""
    out = tmp_path_factory.mktemp("whole") / "ds"
    run = run_dataset(config_file, out=out, count=COUNT, progress=False)
    assert (run.rendered, run.indices) == (COUNT, range(COUNT))
    return out


def _samples(root: Path) -> list[str]:
    parent = root / SCENES
    return sorted(p.name for p in parent.iterdir()) if parent.is_dir() else []


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(("indices", "error", "match"), [
    (range(4, 4), ParameterError, r"non-empty range .* got range\(4, 4\)"),
    (range(5, 2), ParameterError, r"non-empty range .* got range\(5, 2\)"),
    (range(2, 7), ParameterError, r"inside 0:6 \(count is 6\), got range\(2, 7\); .*raise count"),
    (range(-1, 3), ParameterError, r"inside 0:6"),
    (range(0, 6, 2), ParameterError, r"step 1\), got range\(0, 6, 2\)"),
    (slice(0, 3), ParameterTypeError, r"expected a range such as range\(1000, 2000\), got slice"),
    ([0, 1], ParameterTypeError, r"got list"),
])
def test_bad_indices_are_refused_before_any_file(tmp_path, indices, error, match):
    with pytest.raises(error, match=match):
        run_dataset(loads_config(CONFIG), out=tmp_path / "ds", count=COUNT, indices=indices,
                    progress=False)
    assert not (tmp_path / "ds").exists()


def test_a_part_of_a_webdataset_is_refused(tmp_path):
    with pytest.raises(ParameterError, match=r"--format webdataset fills its shards in index "
                                             r"order"):
        run_dataset(loads_config(CONFIG), out=tmp_path / "ds", count=COUNT, fmt="webdataset",
                    indices=range(0, 3), progress=False)
    assert not (tmp_path / "ds").exists()


@pytest.mark.parametrize(("args", "words"), [
    (["--indices", "5:2"], ["--indices", "'5:2'", "START < STOP"]),
    (["--indices", "10:5"], ["inside 0:6", "'10:5'"]),
    (["--indices", "0:7"], ["inside 0:6", "--count is 6", "raise --count"]),
    (["--indices", "9:"], ["inside 0:6", "'9:'"]),
    (["--indices", "abc"], ["expected START:STOP", "'abc'", "1000:2000"]),
    (["--indices", "1:5:2"], ["expected START:STOP", "'1:5:2'"]),
    (["--indices", "3:3"], ["non-empty", "'3:3'"]),
    (["--indices", "0:3", "--format", "webdataset"], ["webdataset", "index order"]),
])
def test_bad_indices_on_the_command_line_give_one_error_line(config_file, tmp_path, args, words):
    result = CliRunner().invoke(main, ["dataset", str(config_file), "--count", str(COUNT),
                                       "--out", str(tmp_path / "ds"), *args])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 2 and len(errors) == 1, result.output
    assert "Traceback" not in result.output
    for word in words:
        assert word in errors[0], (word, errors[0])
    assert not (tmp_path / "ds").exists()


def test_indices_with_verify_is_a_usage_error(tmp_path):
    result = CliRunner().invoke(main, ["dataset", "--verify", str(tmp_path), "--indices", "0:2"])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code == 2 and len(errors) == 1, result.output
    assert "drop it with --verify" in errors[0]


# --------------------------------------------------------------------------- locks
def test_an_overlapping_run_is_refused_while_a_part_runs(tmp_path):
    out = tmp_path / "ds"
    out.mkdir()
    held = RunLock(out, range(2, 4))  # a part over samples 2 and 3, still running
    try:
        for indices, match in [(range(3, 6), r"some of samples 3:6 .* its own --indices range"),
                               (None, r"another run is writing .*waits for every --indices")]:
            with pytest.raises(DatasetError, match=match):
                run_dataset(loads_config(CONFIG), out=out, count=COUNT, indices=indices,
                            progress=False)
        assert sorted(p.name for p in out.iterdir()) == [".lock"]  # refused before dataset.json
    finally:
        held.close()


@pytest.mark.gl
def test_a_part_renders_its_range_only_and_writes_no_manifest(whole, config_file, tmp_path):
    out = tmp_path / "ds"
    first = run_dataset(config_file, out=out, count=COUNT, indices=range(0, 1), progress=False)
    assert (first.rendered, first.skipped) == (1, 0)
    (out / ".000004.tmp-99").mkdir()  # another part's sample in progress
    (out / ".000001.tmp-99").mkdir()  # a stale one of this part's range
    held = RunLock(out, range(4, 6))  # that other part holds samples 4 and 5
    try:
        run = run_dataset(config_file, out=out, count=COUNT, indices=range(0, 3), progress=False)
    finally:
        held.close()
    assert (run.rendered, run.skipped, run.count, run.indices) == (2, 1, COUNT, range(0, 3))
    assert _samples(out) == ["000000", "000001", "000002"]
    assert sorted(p.name for p in (out / "records").iterdir()) == [
        "000000.json", "000001.json", "000002.json"]
    # no manifest, no scene list: a part claims nothing about the whole dataset
    assert sorted(p.name for p in out.iterdir()) == [".000004.tmp-99", ".lock", "MiddEval3",
                                                     "dataset.json", "records"]
    assert sorted(p.name for p in (out / "MiddEval3").iterdir()) == ["trainingF"]
    assert [r["index"] for r in read_manifest(out)] == [0, 1, 2]
    assert "manifest.jsonl: does not match the samples' sample.json (rerun the dataset command " \
        "to rewrite it)" in verify_dataset(out)
    again = run_dataset(config_file, out=out, count=COUNT, indices=range(1, 3), progress=False)
    assert (again.rendered, again.skipped) == (0, 2)
    finish = run_dataset(config_file, out=out, count=COUNT, progress=False)
    assert (finish.rendered, finish.skipped) == (3, 3)
    _assert_same(_tree(out), _tree(whole))  # the whole run removed the stale .tmp too


# --------------------------------------------------------------------------- concurrent parts
_PART = "from synth.cli import main; main()"


@pytest.mark.gl
@pytest.mark.slow
def test_two_part_processes_into_one_folder_then_a_whole_run_equal_one_run(whole, config_file,
                                                                           tmp_path):
    out = tmp_path / "ds"
    procs = [subprocess.Popen([sys.executable, "-c", _PART, "dataset", str(config_file),
                               "--count", str(COUNT), "--out", str(out), "--indices", part],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for part in ("0:3", "3:")]  # started together: both create or check dataset.json
    outputs = [p.communicate(timeout=600) for p in procs]
    for proc, (stdout, stderr) in zip(procs, outputs):
        assert proc.returncode == 0, stderr[-3000:]
    assert outputs[0][0].startswith(f"samples 0:3 of {COUNT} in {out}: 3 rendered, 0 already "
                                    "there"), outputs[0][0]
    assert "rerun without --indices" in outputs[1][0], outputs[1][0]
    assert _samples(out) == [f"{i:06d}" for i in range(COUNT)]
    assert not (out / "manifest.jsonl").exists()
    finish = CliRunner().invoke(main, ["dataset", str(config_file), "--count", str(COUNT),
                                       "--out", str(out)])
    assert finish.exit_code == 0, finish.output
    assert f"{COUNT} samples in {out}: 0 rendered, {COUNT} already there" in finish.output
    _assert_same(_tree(out), _tree(whole))  # manifests, scene list, .lock and all
    assert verify_dataset(out, count=COUNT) == []


@pytest.mark.gl
@pytest.mark.slow
def test_two_part_threads_into_memory_then_a_whole_run_equal_one_run(whole, config_file):
    import fsspec

    url, prefix = "memory://parts-run", "parts-run"
    start = threading.Barrier(2)
    failures: list[BaseException] = []

    def part(indices: range) -> None:
        try:
            start.wait(timeout=60)
            run_dataset(config_file, out=url, count=COUNT, indices=indices, progress=False)
        except BaseException as exc:  # reported by the main thread
            failures.append(exc)

    threads = [threading.Thread(target=part, args=(r,)) for r in (range(0, 2), range(2, COUNT))]
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=600)
        assert not failures, failures
        got = _memory(prefix)
        assert sorted(k for k in got if k.endswith("/sample.json")) == [
            f"{SCENES}/{i:06d}/sample.json" for i in range(COUNT)]
        assert "manifest.jsonl" not in got and "MiddEval3/official_train.txt" not in got
        finish = run_dataset(config_file, out=url, count=COUNT, progress=False)
        assert (finish.rendered, finish.skipped) == (0, COUNT)
        want = {k: v for k, v in _tree(whole).items() if k != ".lock"}  # no lock on a store
        _assert_same(_memory(prefix), want)
    finally:
        fsspec.filesystem("memory").rm(f"/{prefix}", recursive=True)


def test_a_header_written_meanwhile_by_another_driver_is_checked_not_refused(monkeypatch):
    """Object stores have no lock: driver B finds no dataset.json, then driver A writes it and a
    first sample before B lists the prefix; B must check A's header, not call the prefix foreign."""
    import fsspec

    from synth.dataset import run
    from synth.dataset.storage.fs import FsPath, dataset_path

    cfg = loads_config(CONFIG)
    out = dataset_path("memory://parts-header")
    out.mkdir(parents=True, exist_ok=True)
    try:
        run._open_dataset(out, cfg, "middlebury", None, None)  # driver A
        (out / "records" / "000000.json").write_bytes(b"{}")
        header = (out / "dataset.json").read_bytes()
        real, calls = FsPath.is_file, []

        def is_file(self: FsPath) -> bool:  # B's first look comes before A's put
            calls.append(self.name)
            return real(self) and not (self.name == "dataset.json" and calls.count(self.name) == 1)

        monkeypatch.setattr(FsPath, "is_file", is_file)
        run._open_dataset(out, cfg, "middlebury", None, None)  # driver B: no error
        assert calls.count("dataset.json") >= 2 and (out / "dataset.json").read_bytes() == header
        other = loads_config(CONFIG.replace("seed = 0", "seed = 1"), source="other.toml")
        calls.clear()
        with pytest.raises(DatasetError, match="another configuration than other.toml"):
            run._open_dataset(out, other, "middlebury", None, None)
    finally:
        fsspec.filesystem("memory").rm("/parts-header", recursive=True)
