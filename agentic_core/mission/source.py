"""Reading mission files with positions: every problem found later can name its file, line and column.

PyYAML's composed node tree carries marks; we keep the position of every value (and key) by its path in the
document, so a pydantic error at ``steps.2.args.alt_m`` becomes ``mission.yaml:14:15: ...``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import yaml

Path = tuple[str | int, ...]


@dataclass(frozen=True, order=True)
class Problem:
    """One thing wrong with a mission file, printed as ``file:line:col: message``."""

    file: str
    line: int
    col: int
    message: str

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}: {self.message}"


class MissionError(ValueError):
    """A mission that cannot be flown; ``problems`` holds every problem found in it, in file order."""

    def __init__(self, problems: Sequence[Problem]) -> None:
        self.problems = sorted(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


@dataclass
class SourceMap:
    """Where each value (and each mapping key) of a document starts, by path; 1-based lines and columns."""

    file: str
    values: dict[Path, tuple[int, int]] = field(default_factory=dict)
    keys: dict[Path, tuple[int, int]] = field(default_factory=dict)

    def at(self, path: Path, *, key: bool = False) -> tuple[int, int]:
        """The position of ``path``, or of its nearest ancestor that exists (a missing field: its parent)."""
        table = self.keys if key else self.values
        for cut in range(len(path), -1, -1):
            pos = table.get(path[:cut]) or self.values.get(path[:cut])
            if pos is not None:
                return pos
        return (1, 1)

    def problem(self, path: Path, message: str, *, key: bool = False) -> Problem:
        line, col = self.at(path, key=key)
        return Problem(self.file, line, col, message)


def _pos(node: yaml.Node) -> tuple[int, int]:
    return node.start_mark.line + 1, node.start_mark.column + 1


def _walk(node: yaml.Node, path: Path, smap: SourceMap, problems: list[Problem]) -> None:
    smap.values[path] = _pos(node)
    if isinstance(node, yaml.MappingNode):
        seen: dict[str, tuple[int, int]] = {}
        for key_node, value_node in node.value:
            key = str(key_node.value)
            if key in seen:
                line, col = _pos(key_node)
                problems.append(Problem(smap.file, line, col, f"duplicate key {key!r} (first at line {seen[key][0]})"))
                continue
            seen[key] = _pos(key_node)
            smap.keys[(*path, key)] = _pos(key_node)
            _walk(value_node, (*path, key), smap, problems)
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _walk(item, (*path, i), smap, problems)


def load_document(text: str, file: str) -> tuple[Any, SourceMap]:
    """Parse YAML (or JSON, which is YAML) into plain data and its source map; raises :class:`MissionError`."""
    smap = SourceMap(file)
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise MissionError([Problem(file, 1, 1, "the file is empty; a mission needs plan_id, goal and steps")])
        problems: list[Problem] = []
        _walk(node, (), smap, problems)
        if problems:
            raise MissionError(problems)
        data = loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        what = " ".join(p for p in (exc.context, exc.problem) if p)
        raise MissionError([Problem(file, line, col, f"YAML syntax error: {what}")]) from None
    except yaml.YAMLError as exc:
        raise MissionError([Problem(file, 1, 1, f"YAML error: {exc}")]) from None
    finally:
        loader.dispose()
    return data, smap
