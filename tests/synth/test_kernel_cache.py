"""The cold-cache notice: which kernel files numba has not cached, and the two lines printed."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

from synth._util.kernel_cache import (DATASET_KERNELS, MATCHER_KERNELS, _cache_dir, _source,
                                      missing_kernels)


def test_an_empty_cache_misses_every_kernel_file_and_one_index_is_enough(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert missing_kernels(DATASET_KERNELS) == list(DATASET_KERNELS)
    assert missing_kernels(MATCHER_KERNELS) == list(MATCHER_KERNELS)
    source = _source("synth/pair.py")
    folder = _cache_dir(source)
    assert folder.parent == tmp_path
    folder.mkdir()
    tag = f"py{sys.version_info[0]}{sys.version_info[1]}"
    (folder / f"pair._mask_kernel-1.{tag}.nbi").write_bytes(b"")  # wrong line: still missing
    assert "synth/pair.py" in missing_kernels(DATASET_KERNELS)
    line = next(i for i, text in enumerate(source.read_text().splitlines(), 1)
                if text.startswith("def _mask_kernel")) - 1  # its decorator's line
    (folder / f"pair._mask_kernel-{line}.{tag}.nbi").write_bytes(b"")
    assert missing_kernels(DATASET_KERNELS) == ["synth/appearance/photometric.py",
                                                "synth/appearance/_powf.py",
                                                "matcher/_kernels/grey.py",
                                                "matcher/_kernels/canny.py"]


_SCRIPT = """\
from numba import njit
from synth._util.kernel_cache import compile_notice


@njit(cache=True)
def twice(x):
    return 2 * x


with compile_notice(["kpkg/kernels.py"], print) as cold:
    twice(3)
print("cold" if cold else "warm")
"""


def test_a_cold_cache_is_announced_once_and_a_warm_one_is_silent(tmp_path):
    package = tmp_path / "kpkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "kernels.py").write_text(_SCRIPT)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))

    def run() -> list[str]:
        done = subprocess.run([sys.executable, "-c", "import kpkg.kernels"], env=env,
                              capture_output=True, text=True, check=True)
        return done.stdout.splitlines()

    first = run()
    assert len(first) == 3, first
    assert first[0].startswith("compiling numba kernels once (not in numba's cache yet: "
                               "kpkg/kernels.py;")
    assert first[1].startswith("compiled numba kernels in ") and first[1].endswith(" s in all)")
    assert first[2] == "cold"
    assert run() == ["warm"]  # the index numba wrote is found: nothing printed


def test_a_partly_filled_cache_says_nothing(tmp_path, monkeypatch):
    from synth._util.kernel_cache import compile_notice

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    said: list[str] = []
    with compile_notice(["synth/pair.py", "synth/appearance/photometric.py"], said.append) as cold:
        pass
    assert cold and len(said) == 2 and said[0].startswith("compiling numba kernels once")
    source = _source("synth/pair.py")  # one file cached (another method's kernels): no notice
    _cache_dir(source).mkdir()
    line = next(i for i, text in enumerate(source.read_text().splitlines(), 1)
                if text.startswith("def _mask_kernel")) - 1
    tag = f"py{sys.version_info[0]}{sys.version_info[1]}"
    (_cache_dir(source) / f"pair._mask_kernel-{line}.{tag}.nbi").write_bytes(b"")
    said.clear()
    with compile_notice(["synth/pair.py", "synth/appearance/photometric.py"], said.append) as cold:
        pass
    assert not cold and said == []
