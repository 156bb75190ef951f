"""import-linter contract types of our own (registered in pyproject.toml's ``[tool.importlinter]``).

``private_names``: no module imports a ``_private`` name (``from pkg.mod import _helper``) from
another module, except between modules of one kernels package (a package named ``_kernels``,
whose numba helpers are shared on purpose). import-linter's built-in ``private_modules``
contract covers private *modules*; this one covers private *names*, which grimp's graph does not
record, so it reads the source of every module in the graph.
"""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import grimp
from importlinter import Contract, ContractCheck, fields, output

__all__ = ["PrivateNamesContract", "private_name_imports"]


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _in_kernels(module: str) -> bool:
    return "_kernels" in module.split(".")


def _resolve(importer: str, is_package: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    parts = importer.split(".")
    base = parts if is_package else parts[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, node.module] if node.module else base)


def private_name_imports(module: str, path: Path, *, is_package: bool, modules: set[str],
                         exempt_kernels: bool = True) -> list[tuple[int, str, str]]:
    """``(line, imported module, name)`` of every private name ``module`` imports from another.

    ``from pkg import _mod`` of a submodule (one of ``modules``) is an import of a private module,
    left to import-linter's ``private_modules`` contract.
    """
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.ImportFrom):
            continue
        source = _resolve(module, is_package, node)
        if source == module or (exempt_kernels and _in_kernels(source) and _in_kernels(module)):
            continue
        for alias in node.names:
            if _is_private(alias.name) and f"{source}.{alias.name}" not in modules:
                found.append((node.lineno, source, alias.name))
    return found


class PrivateNamesContract(Contract):
    """No ``_private`` name is imported across modules (kernels packages excepted)."""

    type_name = "private_names"
    exempt_kernels = fields.BooleanField(required=False, default=True)

    def check(self, graph: grimp.ImportGraph, verbose: bool) -> ContractCheck:
        offences = []
        modules = set(graph.modules)
        for module in sorted(modules):
            if graph.is_module_squashed(module):
                continue
            spec = importlib.util.find_spec(module)
            if spec is None or not spec.origin or not spec.origin.endswith(".py"):
                continue
            is_package = spec.submodule_search_locations is not None
            for line, source, name in private_name_imports(
                    module, Path(spec.origin), is_package=is_package, modules=modules,
                    exempt_kernels=self.exempt_kernels):  # type: ignore[arg-type]
                offences.append(f"{module}:{line} imports {name} from {source}")
        return ContractCheck(kept=not offences, metadata={"offences": offences})

    def render_broken_contract(self, check: ContractCheck) -> None:
        for offence in check.metadata["offences"]:
            output.print_error(offence, bold=False)
            output.new_line()
        output.print("Make the name public where it is defined, or move the code where it is used.")
