"""The architecture's layer rules, checked on the source: agentic_core.graph imports nothing of the project but
the contracts (models that themselves import nothing of the project); the contracts import nothing of it at all."""

import ast
from pathlib import Path

import agentic_core.contracts
import agentic_core.graph

PROJECT_PACKAGES = {"agentic_core", "tools", "flight", "evaluation", "prompts"}
REPO = Path(agentic_core.__file__).resolve().parents[1]


def imported_modules(path: Path) -> set[str]:
    """Absolute names of the modules a file imports, relative imports resolved against its package."""
    package = ".".join(path.resolve().relative_to(REPO).with_suffix("").parts[:-1])
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                names.add(node.module or "")
                continue
            parts = package.split(".")
            base = parts[: len(parts) - (node.level - 1)]
            names.add(".".join([*base, node.module] if node.module else base))
    return names


def offenders(package: object, allowed: tuple[str, ...]) -> set[str]:
    root = Path(package.__file__).parent  # type: ignore[attr-defined]
    return {
        f"{path.relative_to(root)}: {name}"
        for path in root.rglob("*.py")
        for name in imported_modules(path)
        if name.split(".")[0] in PROJECT_PACKAGES and not name.startswith(allowed)
    }


def test_graph_runtime_imports_nothing_of_the_project_but_the_contracts() -> None:
    found = offenders(agentic_core.graph, ("agentic_core.graph", "agentic_core.contracts"))
    assert not found, found


def test_contracts_import_nothing_of_the_project() -> None:
    found = offenders(agentic_core.contracts, ("agentic_core.contracts",))
    assert not found, found


def test_relative_imports_are_resolved() -> None:
    # The checker itself: a relative import out of the graph package must be seen as the module it names.
    names = imported_modules(Path(agentic_core.graph.__file__).parent / "message.py")
    assert "agentic_core.contracts.messages" in names
