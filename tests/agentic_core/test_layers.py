"""The architecture's layer rule as a table, checked on the source with ast: what each package may import of ours."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
OURS = ("agentic_core", "tools", "flight", "evaluation", "prompts")
LOWER = {"agentic_core.contracts", "agentic_core.graph", "tools", "prompts"}
FLIGHT_CLIENT = {"flight.client", "flight.vehicle", "flight.tools"}
MIDDLE = {"agentic_core.mission", "agentic_core.perception", "agentic_core.reasoning", "agentic_core.memory"}
AGENT = {"agentic_core.agent", "agentic_core.swarm"}
EVERYTHING_BUT_EVALUATION = {"agentic_core", "tools", "flight", "prompts"}

TABLE: dict[str, set[str]] = {
    "agentic_core.contracts": set(),
    "agentic_core.graph": {"agentic_core.contracts"},
    "agentic_core.examples": {"agentic_core.contracts"},
    "tools": {"agentic_core.contracts"},
    "flight": {"agentic_core.contracts", "tools"},
    **{package: set(LOWER) for package in MIDDLE},
    **{package: LOWER | MIDDLE | FLIGHT_CLIENT for package in AGENT},
    **{package: EVERYTHING_BUT_EVALUATION for package in ("agentic_core.run", "agentic_core.console")},
    "agentic_core.prebuilt": EVERYTHING_BUT_EVALUATION,
    "evaluation": set(OURS),
    "agentic_core.cli": set(OURS),
}
"""package (or module) → what of ours it may import, besides itself. Missing packages are rows with no files."""

KNOWN_EXCEPTIONS: dict[str, set[str]] = {}
"""Imports that break a row today, each with the issue that removes it beside it (none since issue 14)."""


def _row(module: str) -> str | None:
    """The most specific row of the table a module falls under."""
    candidates = [row for row in TABLE if module == row or module.startswith(row + ".")]
    return max(candidates, key=len) if candidates else None


def _ours(name: str) -> bool:
    return name.split(".")[0] in OURS


def _imports(path: Path, module: str) -> set[str]:
    names: set[str] = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, *([node.module] if node.module else [])])
                names.update([target] if node.module else [f"{target}.{a.name}" for a in node.names])
            elif node.module:
                names.add(node.module)
    return {name for name in names if _ours(name)}


def _allowed(target: str, row: str) -> bool:
    allowed = TABLE[row] | {row} | KNOWN_EXCEPTIONS.get(row, set())
    return any(target == a or target.startswith(a + ".") for a in allowed)


def _modules() -> list[tuple[Path, str]]:
    found = []
    for top in OURS:
        for path in sorted((ROOT / top).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found.append((path, module))
    return found


def test_the_table_sees_the_source() -> None:
    rows = {_row(module) for _, module in _modules()}
    assert {"agentic_core.contracts", "agentic_core.graph", "tools", "flight", "evaluation"} <= rows


@pytest.mark.parametrize("row", sorted(TABLE))
def test_each_package_imports_only_what_its_row_allows(row: str) -> None:
    offenders = sorted(
        f"{path.relative_to(ROOT)}: {target}"
        for path, module in _modules()
        if _row(module) == row
        for target in _imports(path, module)
        if not _allowed(target, row)
    )
    assert offenders == []


def test_known_exceptions_are_still_needed() -> None:
    """A known exception no longer used is removed from the list, so the table only ever gets stricter."""
    assert set(KNOWN_EXCEPTIONS) <= set(TABLE)
    for row, exceptions in KNOWN_EXCEPTIONS.items():
        used = {
            allowed
            for path, module in _modules()
            if _row(module) == row
            for target in _imports(path, module)
            for allowed in exceptions
            if (target == allowed or target.startswith(allowed + ".")) and not _allowed_without_exceptions(target, row)
        }
        assert used == exceptions, row


def _allowed_without_exceptions(target: str, row: str) -> bool:
    return any(target == a or target.startswith(a + ".") for a in TABLE[row] | {row})


def test_a_forbidden_import_is_caught(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text("from flight.sim import Simulator\nfrom .x import y\n")
    assert not _allowed("flight.sim", "agentic_core.graph")
    assert _imports(probe, "agentic_core.graph.probe") == {"flight.sim", "agentic_core.graph.x"}
