"""The import layering of DESIGN §3, checked on the source (every import, also lazy ones).

graph_store <- queries <- causalsplat; inside causalsplat data flows io -> render ->
field -> instances -> graph, the reasoner never imports the perception side, and graph
construction never imports the reasoner (the OpenAI-compatible client sits apart).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT

#: package prefix -> prefixes it must never import.
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "graph_store": ("queries", "causalsplat", "torch"),
    "queries": ("causalsplat", "torch"),
    "migrations": ("queries", "causalsplat"),
    "causalsplat.io": ("causalsplat.render", "causalsplat.field", "causalsplat.instances",
                       "causalsplat.graph", "causalsplat.reason", "causalsplat.build"),
    "causalsplat.render": ("causalsplat.field", "causalsplat.instances", "causalsplat.graph",
                           "causalsplat.reason", "causalsplat.build"),
    "causalsplat.field": ("causalsplat.instances", "causalsplat.graph", "causalsplat.reason",
                          "causalsplat.build"),
    "causalsplat.instances": ("causalsplat.graph", "causalsplat.reason", "causalsplat.build"),
    "causalsplat.graph": ("causalsplat.reason", "causalsplat.build", "torch"),
    "causalsplat.reason": ("causalsplat.io", "causalsplat.render", "causalsplat.field",
                           "causalsplat.instances", "causalsplat.build", "torch"),
    "causalsplat.openai_compat": ("causalsplat.reason", "causalsplat.build", "torch"),
    "causalsplat.eval": ("causalsplat.render", "causalsplat.field", "torch"),
}  # fmt: skip


def _module_name(path: Path) -> str:
    rel = path.relative_to(REPO_ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def _sources() -> list[Path]:
    roots = ("graph_store", "queries", "migrations", "causalsplat")
    return sorted(p for r in roots for p in (REPO_ROOT / r).rglob("*.py"))


def _within(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_no_import_crosses_a_layer(package: str) -> None:
    bad = []
    for path in _sources():
        module = _module_name(path)
        if not _within(module, package):
            continue
        for name in _imports(path):
            for banned in FORBIDDEN[package]:
                if _within(name, banned):
                    bad.append(f"{module} imports {name}")
    assert not bad, "\n".join(sorted(set(bad)))


def test_the_check_sees_every_package() -> None:
    modules = {_module_name(p) for p in _sources()}
    for package in FORBIDDEN:
        assert any(_within(m, package) for m in modules), package
