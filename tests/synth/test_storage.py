"""Datasets written to fsspec URLs (``memory://`` here): the bytes, resume and verify of folders."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from stereoforge.errors import DatasetError
from synth.dataset.storage.fs import FsPath, dataset_path

_CONFIG = ("seed = 4\ncount = 3\n[rig]\nwidth = 32\nheight = 24\n[scene]\nbase = 'flying'\n"
           "[photometric]\nnoise_sigma = 2.0\n")


def _folder(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and p.name != ".lock"}


def _memory(prefix: str) -> dict[str, bytes]:
    import fsspec

    fs = fsspec.filesystem("memory")
    return {f.removeprefix(f"/{prefix}/"): fs.cat_file(f) for f in fs.find(f"/{prefix}")}


def test_paths_and_urls():
    assert dataset_path("file:///tmp/x") == Path("/tmp/x")
    assert dataset_path("a/b") == Path("a/b")
    p = dataset_path("memory://store-test/x")
    assert isinstance(p, FsPath) and str(p / "y") == "memory://store-test/x/y"


def test_a_url_whose_filesystem_is_missing_names_the_package(tmp_path, monkeypatch):
    import importlib.util

    if importlib.util.find_spec("s3fs") is None:  # the usual case, CI included
        with pytest.raises(DatasetError, match=r"s3:// filesystem is not installed.*pip install "
                                               r"s3fs"):
            dataset_path("s3://bucket/data")
    with pytest.raises(DatasetError, match="fsspec knows no filesystem 'nosuch'"):
        dataset_path("nosuch://x")
    monkeypatch.setitem(sys.modules, "fsspec", None)  # fsspec itself not installed
    with pytest.raises(DatasetError, match=r"pip install 'stereoforge\[storage\]'"):
        dataset_path("memory://x")


def test_the_cli_refuses_a_missing_filesystem_before_any_work(tmp_path):
    from click.testing import CliRunner

    from synth.cli import main

    result = CliRunner().invoke(main, ["dataset", "planes", "--count", "1", "--out",
                                       "nosuch://bucket/x"])
    errors = [line for line in result.output.splitlines() if line.startswith("Error:")]
    assert result.exit_code != 0 and len(errors) == 1, result.output
    assert "nosuch://bucket/x" in errors[0] and "Traceback" not in result.output


@pytest.mark.gl
def test_memory_url_has_the_folder_bytes_resumes_and_verifies(tmp_path, renderer):
    import fsspec

    import synth
    from synth.dataset.config.parse import loads_config
    from synth.dataset.storage.integrity import verify_dataset

    cfg = loads_config(_CONFIG)
    synth.run_dataset(cfg, tmp_path / "f", progress=False)  # the public entry point, out positional
    run = synth.run_dataset(cfg, "memory://store-run", progress=False)
    assert run.rendered == 3 and _memory("store-run") == _folder(tmp_path / "f")
    assert verify_dataset("memory://store-run") == []
    fs = fsspec.filesystem("memory")
    # a sample whose record is gone, or whose file is truncated, is rendered again
    fs.rm("/store-run/records/000001.json")
    sample2 = "/store-run/MiddEval3/trainingF/000002/im0.png"
    fs.pipe_file(sample2, fs.cat_file(sample2)[:-5])
    problems = verify_dataset("memory://store-run")
    assert any("000001: no completion record" in p for p in problems), problems
    assert any("000002/im0.png" in p and "truncated" in p for p in problems), problems
    run = synth.run_dataset(cfg, "memory://store-run", progress=False)
    assert (run.rendered, run.skipped) == (2, 1)
    assert _memory("store-run") == _folder(tmp_path / "f")
    fs.rm("/store-run", recursive=True)


@pytest.mark.gl
def test_a_sample_of_a_url_dataset_is_rendered_again_from_its_manifest(tmp_path, renderer):
    """render --from-manifest reads dataset.json and the sample's record from the URL itself."""
    from click.testing import CliRunner

    import synth
    from synth.cli import main
    from synth.dataset.config.parse import loads_config

    synth.run_dataset(loads_config(_CONFIG), "memory://store-again", progress=False)
    try:
        result = CliRunner().invoke(main, ["render", "--from-manifest", "memory://store-again",
                                           "2", "--out", str(tmp_path / "again")])
        assert result.exit_code == 0, result.output
        stored = {k.split("/000002/", 1)[1]: v for k, v in _memory("store-again").items()
                  if "/000002/" in k}
        again = _folder(tmp_path / "again")
        assert len(stored) > 5 and again == stored
        missing = CliRunner().invoke(main, ["render", "--from-manifest", "memory://no-such",
                                            "0", "--out", str(tmp_path / "none")])
        errors = [line for line in missing.output.splitlines() if line.startswith("Error:")]
        assert missing.exit_code != 0 and len(errors) == 1, missing.output
        assert "memory://no-such has no dataset.json" in errors[0]
        assert not (tmp_path / "none").exists()
    finally:
        import fsspec

        fsspec.filesystem("memory").rm("/store-again", recursive=True)


_PREIMPORTED = """
import ray  # before the engine, without RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER: too late to keep 127.0.0.1
from stereoforge.errors import BackendError
from synth.dataset.engine.tasks import run_tasks

class T:
    width, height, backend = 8, 8, "auto"
    def __call__(self, index, renderer):
        return {}

try:
    list(run_tasks(T(), [0], engine="ray"))
except BackendError as exc:
    print(exc)
"""


def test_ray_imported_without_the_loopback_setting_is_refused_with_the_fix(require_or_skip):
    from synth.dataset.engine.tasks import ray_available

    if not ray_available():
        require_or_skip("ray is not installed (optional extra: pip install ray)",
                        env="STEREOFORGE_REQUIRE_RAY")
    env = {k: v for k, v in os.environ.items() if k != "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"}
    out = subprocess.run([sys.executable, "-c", _PREIMPORTED], capture_output=True, text=True,
                         timeout=120, env=env)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "a local Ray is on the loopback" in out.stdout
    assert "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0" in out.stdout


@pytest.mark.gl
@pytest.mark.parametrize("fmt", ["sceneflow", "crestereo", "fsd"])
def test_a_training_layout_on_a_url_has_the_folder_bytes(tmp_path, renderer, fmt):
    """The files a layout places outside the sample folder (SceneFlow's tree, CREStereo's and
    FSD's) travel as returned bytes, as from Ray workers, and land at their paths."""
    import fsspec

    import synth
    from synth.dataset.config.parse import loads_config
    from synth.dataset.storage.integrity import verify_dataset

    cfg = loads_config(_CONFIG)
    synth.run_dataset(cfg, tmp_path / "f", fmt=fmt, progress=False)
    synth.run_dataset(cfg, f"memory://store-{fmt}", fmt=fmt, progress=False)
    assert _memory(f"store-{fmt}") == _folder(tmp_path / "f")
    assert verify_dataset(f"memory://store-{fmt}") == []
    fsspec.filesystem("memory").rm(f"/store-{fmt}", recursive=True)
