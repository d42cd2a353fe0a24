"""YAML (or JSON) files read with their node positions, so a problem found in the data can name its line and column.

Problems are :class:`~agentic_core.contracts.problems.LocatedProblem` (``file:line:col: field: message``), found
with the one YAML position helper, :func:`~agentic_core.contracts.yaml_positions.position_at`.

>>> import tempfile
>>> path = Path(tempfile.mkdtemp()) / "f.yaml"
>>> _ = path.write_text("tools:\\n  - name: a.b\\n    method: FETCH\\n")
>>> source = YamlSource.read(path)
>>> source.data["tools"][0]["method"], source.position(("tools", 0, "method"))
('FETCH', (3, 5))
>>> problem = source.problem(("tools", 0, "method"), "unknown method")
>>> (problem.line, problem.col), str(problem).endswith("f.yaml:3:5: tools[0].method: unknown method")
((3, 5), True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from agentic_core.contracts.input_files import InputFileError, check_input_file
from agentic_core.contracts.problems import LocatedProblem
from agentic_core.contracts.yaml_positions import position_at

from .errors import ToolDefinitionError

Loc = tuple[str | int, ...]
"""A path into the data: mapping keys and list indexes, as pydantic reports an error's ``loc``."""


def dotted(loc: Sequence[str | int]) -> str:
    """``("tools", 0, "method")`` as ``tools[0].method``."""
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "(top)"


@dataclass(frozen=True)
class YamlSource:
    """A file's data and its node tree (``root`` is None for an empty file)."""

    path: Path
    root: yaml.Node | None
    data: Any

    @classmethod
    def read(cls, path: str | Path) -> YamlSource:
        """Read and parse a file; an unreadable file or a syntax error is a :class:`ToolDefinitionError` naming
        the line and column."""
        path = Path(path)
        file = str(path)
        try:
            check_input_file(path, "tool file")
            text = path.read_text(encoding="utf-8")
        except InputFileError as exc:
            raise ToolDefinitionError([LocatedProblem(file, None, None, exc.reason)]) from None
        except (OSError, UnicodeDecodeError) as exc:
            raise ToolDefinitionError([LocatedProblem(file, None, None, f"cannot read it: {exc}")]) from None
        loader = yaml.SafeLoader(text)
        try:
            root = loader.get_single_node()
            return cls(path, root, loader.construct_document(root) if root is not None else None)
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            line, col = (mark.line + 1, mark.column + 1) if mark else (None, None)
            message = f"not valid YAML or JSON: {exc.problem or exc.context}"
            raise ToolDefinitionError([LocatedProblem(file, line, col, message)]) from None
        except yaml.YAMLError as exc:
            raise ToolDefinitionError([LocatedProblem(file, None, None, f"not valid YAML or JSON: {exc}")]) from None
        finally:
            loader.dispose()

    def position(self, loc: Loc) -> tuple[int, int]:
        """Line and column of the field at ``loc``: its key for a mapping entry, the item for a list entry, the
        nearest enclosing value when the field is missing; the file's start when it is empty."""
        return (1, 1) if self.root is None else position_at(self.root, loc, key=True)

    def problem(self, loc: Loc, message: str) -> LocatedProblem:
        """The problem ``message`` of the field at ``loc``: ``file:line:col: field: message``."""
        line, col = self.position(loc)
        return LocatedProblem(str(self.path), line, col, f"{dotted(loc)}: {message}")

    def duplicate_keys(self) -> list[tuple[Loc, str]]:
        """Keys written twice in one mapping, at the last one (which a YAML loader silently keeps)."""
        found: list[tuple[Loc, str]] = []

        def walk(node: yaml.Node, loc: Loc) -> None:
            if isinstance(node, yaml.MappingNode):
                first: dict[str, int] = {}
                for key, value in node.value:
                    name = str(key.value)
                    if name in first:
                        found.append(((*loc, name), f"{name!r} is written twice (first at line {first[name]})"))
                    first.setdefault(name, key.start_mark.line + 1)
                    walk(value, (*loc, name))
            elif isinstance(node, yaml.SequenceNode):
                for index, item in enumerate(node.value):
                    walk(item, (*loc, index))

        if self.root is not None:
            walk(self.root, ())
        return found


__all__ = ["Loc", "YamlSource", "dotted"]
