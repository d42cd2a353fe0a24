"""YAML (or JSON) files read with their node positions, so a problem found in the data can name its line and column.

>>> import tempfile
>>> path = Path(tempfile.mkdtemp()) / "f.yaml"
>>> _ = path.write_text("tools:\\n  - name: a.b\\n    method: FETCH\\n")
>>> source = YamlSource.read(path)
>>> source.data["tools"][0]["method"], source.where(("tools", 0, "method")).endswith("f.yaml:3:5")
('FETCH', True)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

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
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ToolDefinitionError(f"{path}: cannot read it: {exc}") from None
        loader = yaml.SafeLoader(text)
        try:
            root = loader.get_single_node()
            return cls(path, root, loader.construct_document(root) if root is not None else None)
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            where = f"{path}:{mark.line + 1}:{mark.column + 1}" if mark else str(path)
            raise ToolDefinitionError(f"{where}: not valid YAML or JSON: {exc.problem or exc.context}") from None
        except yaml.YAMLError as exc:
            raise ToolDefinitionError(f"{path}: not valid YAML or JSON: {exc}") from None
        finally:
            loader.dispose()

    def mark(self, loc: Loc) -> yaml.Mark | None:
        """Where the field at ``loc`` is written: its key for a mapping entry, the item for a list entry; the
        deepest enclosing node when the field is missing."""
        if self.root is None:
            return None
        node, mark = self.root, self.root.start_mark
        for part in loc:
            if isinstance(node, yaml.MappingNode):
                keys = [kv for kv in node.value if isinstance(kv[0], yaml.ScalarNode) and kv[0].value == str(part)]
                entry = keys[0] if keys else None
                if entry is None:
                    break
                mark, node = entry[0].start_mark, entry[1]
            elif isinstance(node, yaml.SequenceNode) and isinstance(part, int) and 0 <= part < len(node.value):
                node = node.value[part]
                mark = node.start_mark
            else:
                break
        return mark

    def where(self, loc: Loc) -> str:
        """``file:line:column`` of the field at ``loc``."""
        mark = self.mark(loc)
        return f"{self.path}:{mark.line + 1}:{mark.column + 1}" if mark is not None else f"{self.path}:1:1"

    def problem(self, loc: Loc, message: str) -> str:
        """``file:line:column: field: message``."""
        return f"{self.where(loc)}: {dotted(loc)}: {message}"

    def duplicate_keys(self) -> list[tuple[Loc, str]]:
        """Keys written twice in one mapping (a YAML loader silently keeps the last)."""
        found: list[tuple[Loc, str]] = []

        def walk(node: yaml.Node, loc: Loc) -> None:
            if isinstance(node, yaml.MappingNode):
                seen: set[str] = set()
                for key, value in node.value:
                    name = str(key.value)
                    if name in seen:
                        again = f"again at line {key.start_mark.line + 1}"
                        found.append(((*loc, name), f"{name!r} is written twice ({again}; the last one would win)"))
                    seen.add(name)
                    walk(value, (*loc, name))
            elif isinstance(node, yaml.SequenceNode):
                for index, item in enumerate(node.value):
                    walk(item, (*loc, index))

        if self.root is not None:
            walk(self.root, ())
        return found


__all__ = ["Loc", "YamlSource", "dotted"]
