"""The dependency contract between packages (STYLE.md: scenes <- synth -> matcher)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
GL_MODULES = ("pyrender", "OpenGL")


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_matcher_and_scenes_import_without_synth_or_gl():
    code = (
        "import sys, matcher, scenes\n"
        "bad = sorted({m.split('.')[0] for m in sys.modules} & {'synth', 'pyrender', 'OpenGL'})\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


@pytest.mark.parametrize(
    ("package", "forbidden"),
    [("matcher", {"synth", "scenes", *GL_MODULES}), ("scenes", {"synth", "matcher", *GL_MODULES})],
)
def test_package_does_not_import_forbidden(package, forbidden):
    offenders = {
        str(p.relative_to(SRC)): sorted(_imports(p) & forbidden)
        for p in (SRC / package).rglob("*.py")
        if _imports(p) & forbidden
    }
    assert offenders == {}


def test_only_render_module_imports_gl():
    users = sorted(
        str(p.relative_to(SRC)) for p in (SRC / "synth").rglob("*.py") if _imports(p) & set(GL_MODULES)
    )
    assert users == ["synth/render/context.py", "synth/render/renderer.py"]


def test_importing_synth_does_not_start_gl():
    code = "import sys, synth, synth.pair, synth.cli; print(sorted({'pyrender','OpenGL'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


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
