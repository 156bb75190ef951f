"""The README's examples run: the Python API in ten lines, and property-testing OpenCV StereoBM."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_property_test_example_runs_and_passes():
    text = README.read_text()
    blocks = re.findall(r"```python\n(# property-test.*?)```", text, flags=re.S)
    assert len(blocks) == 1, "README must hold exactly one '# property-test' python block"
    namespace: dict = {}
    exec(compile(blocks[0], str(README), "exec"), namespace)  # defines the test function
    tests = [v for k, v in namespace.items() if k.startswith("test_") and callable(v)]
    assert len(tests) == 1
    tests[0]()  # a hypothesis test: runs its examples, raises on a counter-example


def _python_api_block() -> str:
    blocks = re.findall(r"## Python API\n\n```python\n(.*?)```", README.read_text(), flags=re.S)
    assert len(blocks) == 1, "README must hold one python block right under '## Python API'"
    return blocks[0]


def test_readme_python_api_imports_from_the_packages_only():
    imports = [line for line in _python_api_block().splitlines() if line.startswith(("from ", "import "))]
    assert imports, "the Python API example imports nothing"
    modules = [line.split()[1] for line in imports]
    assert all("." not in m for m in modules), f"import from the package, not its modules: {modules}"


@pytest.mark.gl
def test_readme_python_api_example_runs(require_or_skip):
    from synth import GLBackendError, resolve_backend

    try:
        resolve_backend("auto")
    except GLBackendError as exc:
        require_or_skip(f"no OpenGL backend: {exc}", env="STEREOFORGE_REQUIRE_GL")
    out = subprocess.run([sys.executable, "-c", _python_api_block()], capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert "pobmp" in out.stdout, out.stdout  # it prints the metrics of the match
