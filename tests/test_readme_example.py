"""The README's example of property-testing someone else's matcher (OpenCV StereoBM) runs."""

from __future__ import annotations

import re
from pathlib import Path

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
