"""The benchmark scripts hold together: each imports, and every ``module.name`` one of them
reads from another benchmarks module exists there.  They run for minutes on shared data,
so the suite does not run them; a name moved between modules (as when a script was split)
would otherwise only show when someone next runs the script."""
from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p.stem for p in BENCHMARKS.glob("*.py") if p.stem != "__init__")


def _benchmark_aliases(tree: ast.Module) -> dict:
    """alias -> benchmarks module name, for ``from benchmarks import x [as y]`` and
    ``import benchmarks.x as y`` anywhere in the file."""
    out = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module == "benchmarks":
            for a in node.names:
                out[a.asname or a.name] = a.name
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("benchmarks.") and a.asname:
                    out[a.asname] = a.name.split(".", 1)[1]
    return out


@pytest.mark.parametrize("name", SCRIPTS)
def test_the_script_imports_and_its_references_resolve(name):
    module = importlib.import_module(f"benchmarks.{name}")
    tree = ast.parse((BENCHMARKS / f"{name}.py").read_text(encoding="utf-8"))
    aliases = _benchmark_aliases(tree)
    missing = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                and node.value.id in aliases and isinstance(node.ctx, ast.Load):
            other = importlib.import_module(f"benchmarks.{aliases[node.value.id]}")
            if not hasattr(other, node.attr):
                missing.append(f"{node.value.id}.{node.attr} (line {node.lineno})")
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("benchmarks."):
            other = importlib.import_module(node.module)
            missing += [f"{node.module}.{a.name} (line {node.lineno})"
                        for a in node.names if a.name != "*" and not hasattr(other, a.name)]
    assert module is not None and missing == []
