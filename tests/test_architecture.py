"""The dependency rules of docs/architecture.md: import-linter contracts, and what they can't see.

The contracts live in pyproject.toml (``[tool.importlinter]``); ``private_names`` is our own
contract type (tools/import_contracts.py). Each contract is one test, so a broken rule names
itself. The runtime checks below cover what a static graph does not: what importing a package
actually loads.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
CONTRACTS = [c["name"] for c in
             tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]]

sys.path.insert(0, str(ROOT / "tools"))
from import_contracts import private_name_imports  # noqa: E402

sys.path.remove(str(ROOT / "tools"))


@pytest.fixture(scope="module")
def lint_report() -> str:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "tools"), str(SRC)])}
    code = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"
    out = subprocess.run([sys.executable, "-c", code, "--no-cache"], capture_output=True, text=True,
                         cwd=ROOT, env=env)
    assert "Contracts:" in out.stdout, out.stdout + out.stderr
    return out.stdout


@pytest.mark.parametrize("contract", CONTRACTS)
def test_import_contract_is_kept(lint_report, contract):
    lines = [line for line in lint_report.splitlines() if line.startswith(contract + " ")]
    assert lines, f"contract {contract!r} was not checked:\n{lint_report}"
    assert lines[0].endswith("KEPT"), lint_report[lint_report.rfind(contract):]


def test_private_names_contract_finds_a_planted_import(tmp_path):
    (tmp_path / "b.py").write_text(
        "from pkg.a import _helper, public\n"
        "from pkg import _sub\n"            # a private module: the private_modules contract's
        "from . import _other\n"
        "from pkg.a import __version__\n"   # dunder: not private
    )
    found = private_name_imports("pkg.b", tmp_path / "b.py", is_package=False,
                                 modules={"pkg", "pkg.a", "pkg.b", "pkg._sub"})
    assert found == [(1, "pkg.a", "_helper"), (3, "pkg", "_other")]


def test_private_names_contract_exempts_kernels_packages_only_among_themselves(tmp_path):
    (tmp_path / "k.py").write_text("from matcher._kernels.census import _row\n")
    inside = private_name_imports("matcher._kernels.adaptive", tmp_path / "k.py", is_package=False,
                                  modules=set())
    outside = private_name_imports("matcher.adaptive", tmp_path / "k.py", is_package=False,
                                   modules=set())
    assert inside == [] and outside == [(1, "matcher._kernels.census", "_row")]


def _loaded_after(statement: str, prefixes: tuple[str, ...]) -> list[str]:
    code = (f"import sys; {statement}\n"
            f"print(','.join(sorted({{m.split('.')[0] for m in sys.modules}} & {set(prefixes)!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return [m for m in out.stdout.strip().split(",") if m]


def test_matcher_and_scenes_import_without_synth_or_gl():
    assert _loaded_after("import matcher, scenes, matcher.io", ("synth", "pyrender", "OpenGL")) == []


def test_nothing_but_the_learning_modules_loads_torch():
    """torch is an optional extra: the library, the CLI and every non-learning job load without it."""
    statement = ("import matcher, matcher.io, matcher.adapters, scenes, synth, synth.cli, "
                 "synth.dataset.run, synth.validate.run, synth.jobs.study.run, "
                 "synth.jobs.bench.match, synth.jobs.bench.transfer; "
                 "matcher.resolve_matcher('ct:9')")
    assert _loaded_after(statement, ("torch",)) == []


def test_without_torch_matcher_works_and_learned_strings_name_the_extra(tmp_path):
    code = ("import sys; sys.modules['torch'] = None\n"
            "import numpy as np, matcher\n"
            "img = np.random.default_rng(0).integers(0, 255, (24, 40), dtype=np.uint8)\n"
            "matcher.match(img, img, method='ct', window=5, max_disparity=8)\n"
            "try:\n"
            f"    matcher.resolve_matcher('learned:{tmp_path}/m.pt')\n"
            "except matcher.MatcherError as exc:\n"
            "    print(exc)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "pip install 'stereoforge[learn]'" in out.stdout


_NO_TORCH = ("import sys\n"
             "class _NoTorch:\n"
             "    def find_spec(self, name, path=None, target=None):\n"
             "        if name.split('.')[0] == 'torch':\n"
             "            raise ModuleNotFoundError(f'No module named {name!r}', name=name)\n"
             "sys.meta_path.insert(0, _NoTorch())\n"
             "from synth.cli import main\n"
             "main()\n")


@pytest.mark.parametrize("args", [["train", "data", "--out", "m.pt", "--steps", "1"],
                                  ["bench", "transfer", "--out", "o", "--no-ceiling"]],
                         ids=["train", "bench transfer"])
def test_without_torch_the_learning_commands_name_the_extra(tmp_path, args):
    out = subprocess.run([sys.executable, "-c", _NO_TORCH, *args], capture_output=True,
                         text=True, cwd=tmp_path)
    assert out.returncode == 1, out.stderr
    assert out.stderr.strip().splitlines() == [
        "Error: this command needs the optional package torch, which is not installed; "
        "pip install 'stereoforge[learn]'"]
    assert list(tmp_path.iterdir()) == []


def test_importing_synth_and_its_cli_starts_no_gl():
    statement = "import synth, synth.pair, synth.cli, synth.render, synth.dataset.run"
    assert _loaded_after(statement, ("pyrender", "OpenGL")) == []


def test_import_synth_and_the_cli_are_light():
    """``synth`` and ``synth.cli`` load their names on first use: --help imports no numba/trimesh."""
    statement = "import synth, synth.cli, synth.dataset.engine.tasks"
    assert _loaded_after(statement, ("numba", "trimesh", "cv2")) == []


@pytest.mark.parametrize("package", ["synth", "synth.dataset", "synth.render", "matcher", "scenes"])
def test_every_public_name_resolves(package):
    code = (f"import importlib; m = importlib.import_module({package!r})\n"
            "missing = [n for n in m.__all__ if not hasattr(m, n)]\n"
            "assert m.__all__ and not missing, missing\n"
            "assert set(m.__all__) <= set(dir(m))\n")
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("init", sorted(SRC.rglob("__init__.py")), ids=lambda p: str(p.relative_to(SRC)))
def test_init_has_all_and_no_star_imports(init):
    tree = ast.parse(init.read_text())
    assert any(
        isinstance(node, (ast.Assign, ast.AnnAssign))
        and any(getattr(t, "id", None) == "__all__" for t in getattr(node, "targets", [getattr(node, "target", None)]))
        for node in tree.body
    ), f"{init} lacks __all__"
    stars = [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and any(a.name == "*" for a in n.names)]
    assert stars == []


def _format_names() -> set[str]:
    from synth.formats import layouts

    return {n for layout in layouts() for n in (layout.name, layout.kind)}


def format_name_comparisons(source: str, names: set[str]) -> list[int]:
    """Lines of ``source`` that compare a value with a format's name (``== "kitti"``, ``in
    ("sceneflow", ...)``): the branches on a format that belong in its layout."""
    def named(node: ast.AST) -> bool:
        if isinstance(node, ast.Constant):
            return node.value in names
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return any(named(e) for e in node.elts)
        return False

    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare) and any(
                isinstance(op, (ast.Eq, ast.NotEq, ast.In, ast.NotIn)) for op in node.ops):
            if any(named(side) for side in (node.left, *node.comparators)):
                lines.append(node.lineno)
    return lines


def test_no_code_outside_the_formats_compares_a_format_name():
    names = _format_names()
    assert {"middlebury", "kitti", "kitti2015", "eth3d", "skimage"} <= names
    found = []
    for path in sorted(SRC.rglob("*.py")):
        if (SRC / "synth" / "formats") in path.parents:
            continue
        found += [f"{path.relative_to(SRC)}:{n}"
                  for n in format_name_comparisons(path.read_text(), names)]
    assert found == []


def test_the_format_name_check_finds_a_planted_branch():
    names = {"kitti", "sceneflow"}
    planted = ("if fmt == 'kitti':\n    pass\nx = kind in ('sceneflow', 'a')\n"
               "y = 'kitti' != fmt\nz = fmt == 'other'\nw = {'kitti': 1}\n")
    assert format_name_comparisons(planted, names) == [1, 3, 4]


def _module_lines() -> dict[str, int]:
    return {p.relative_to(SRC).as_posix(): len(p.read_text().splitlines())
            for p in SRC.rglob("*.py")}


def test_no_module_is_over_500_lines_and_the_size_table_is_true():
    lines = _module_lines()
    assert {m: n for m, n in lines.items() if n > 500} == {}
    text = (ROOT / "docs" / "architecture.md").read_text()
    section = text[text.index("## Modules over 400 lines"):]
    section = section[:section.index("\n## ", 3)]
    table = {m: int(n) for m, n in
             (row.split("|")[1:3] for row in section.splitlines() if row.startswith("| `"))
             for m, n in [(m.strip().strip("`"), n.strip())]}
    want = {m: n for m, n in lines.items() if n > 400}
    assert table == want, ("docs/architecture.md's table of modules over 400 lines: "
                           f"rows to change {sorted(set(table.items()) ^ set(want.items()))}")
