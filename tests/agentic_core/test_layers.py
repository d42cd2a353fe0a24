"""The architecture's layer rule, checked on the source: agentic_core.graph imports nothing of the project."""

import ast
from pathlib import Path

import agentic_core.graph

PROJECT_PACKAGES = {"agentic_core", "tools", "flight", "evaluation", "prompts"}


def imported_modules(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_graph_runtime_imports_nothing_of_the_project() -> None:
    root = Path(agentic_core.graph.__file__).parent
    offenders = {
        f"{path.relative_to(root)}: {name}"
        for path in root.rglob("*.py")
        for name in imported_modules(path)
        if name.split(".")[0] in PROJECT_PACKAGES
    }
    assert not offenders, offenders
