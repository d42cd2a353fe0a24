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
    """Where each value (and each mapping key) of a document starts, by path; 1-based lines and columns.

    Positions are looked up in the composed YAML tree only when a problem needs one, so loading a valid
    mission pays nothing for them. ``problems`` holds what was wrong but did not stop loading (a duplicate
    key); validation reports them with everything else it finds."""

    file: str
    root: yaml.Node | None = None
    problems: list[Problem] = field(default_factory=list)

    def _find(self, path: Path) -> tuple[yaml.Node | None, yaml.Node | None, int]:
        """The value node and key node at ``path`` (the deepest that exists), and how many parts matched."""
        node, key_node, depth = self.root, None, 0
        for part in path:
            nxt = key = None
            if isinstance(node, yaml.MappingNode):
                for k, v in reversed(node.value):  # the last of duplicate keys wins, as when loading
                    if isinstance(k, yaml.ScalarNode) and (k.value == part or k.value == str(part)):
                        nxt, key = v, k
                        break
            elif isinstance(node, yaml.SequenceNode) and isinstance(part, int) and part < len(node.value):
                nxt = node.value[part]
            if nxt is None:
                break
            node, key_node, depth = nxt, key, depth + 1
        return node, key_node, depth

    def at(self, path: Path, *, key: bool = False) -> tuple[int, int]:
        """The position of ``path``, or of its nearest ancestor that exists (a missing field: its parent)."""
        node, key_node, depth = self._find(path)
        target = key_node if key and key_node is not None and depth == len(path) else node
        return _pos(target) if target is not None else (1, 1)

    def problem(self, path: Path, message: str, *, key: bool = False) -> Problem:
        line, col = self.at(path, key=key)
        return Problem(self.file, line, col, message)


def _pos(node: yaml.Node) -> tuple[int, int]:
    return node.start_mark.line + 1, node.start_mark.column + 1


def _build(node: yaml.Node, smap: SourceMap, loader: yaml.SafeLoader, active: set[int]) -> Any:
    """Construct the value of ``node``, noting duplicate keys and refusing aliases that refer to themselves."""
    if id(node) in active:
        line, col = _pos(node)
        raise MissionError(
            [Problem(smap.file, line, col, "a YAML alias refers to itself: the document would be infinite")]
        )
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, tuple[int, int]] = {}
        for key_node, _ in node.value:  # duplicates among the keys as written (merged ones may be overridden)
            if key_node.tag == "tag:yaml.org,2002:merge" or not isinstance(key_node, yaml.ScalarNode):
                continue
            key = key_node.value
            if key in seen:
                line, col = _pos(key_node)
                message = f"duplicate key {key!r} (first at line {seen[key][0]}); the last wins"
                smap.problems.append(Problem(smap.file, line, col, message))
            seen[key] = _pos(key_node)
        loader.flatten_mapping(node)  # YAML merge keys: <<: *defaults
        active.add(id(node))
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node) if isinstance(key_node, yaml.ScalarNode) else None
            if key is None or isinstance(key, list | dict):
                line, col = _pos(key_node)
                raise MissionError([Problem(smap.file, line, col, "a mapping key must be a plain name or number")])
            out[key] = _build(value_node, smap, loader, active)
        active.discard(id(node))
        return out
    if isinstance(node, yaml.SequenceNode):
        active.add(id(node))
        items = [_build(item, smap, loader, active) for item in node.value]
        active.discard(id(node))
        return items
    if node.tag == _STR_TAG:
        return node.value  # most scalars: no constructor needed
    construct = loader.yaml_constructors.get(node.tag)
    return construct(loader, node) if construct is not None else loader.construct_object(node)


_STR_TAG = "tag:yaml.org,2002:str"


_Loader: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml when present: 10x faster


def _yaml_problem(file: str, exc: yaml.MarkedYAMLError) -> Problem:
    mark = exc.problem_mark or exc.context_mark
    line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
    message = f"YAML syntax error: {exc.problem or 'invalid YAML'}"
    if exc.context:
        started = f" at line {exc.context_mark.line + 1}" if exc.context_mark else ""
        message += f" ({exc.context}{started})"
    return Problem(file, line, col, message)


def _position_of(text: str, index: int) -> tuple[int, int]:
    before = text[:index]
    return before.count("\n") + 1, index - (before.rfind("\n") + 1) + 1


def load_document(text: str, file: str) -> tuple[Any, SourceMap]:
    """Parse YAML (or JSON, which is YAML) into plain data and its source map; raises :class:`MissionError`."""
    smap = SourceMap(file)
    loader: yaml.SafeLoader | None = None
    try:
        loader = _Loader(text)
        node = loader.get_single_node()
        if node is None:
            raise MissionError([Problem(file, 1, 1, "the file is empty; a mission needs plan_id, goal and steps")])
        smap.root = node
        data = _build(node, smap, loader, set())
    except yaml.MarkedYAMLError as exc:
        raise MissionError([_yaml_problem(file, exc)]) from None
    except yaml.reader.ReaderError as exc:
        line, col = _position_of(text, exc.position)
        char = exc.character if isinstance(exc.character, int) else ord(str(exc.character)[:1] or "\0")
        message = f"YAML cannot contain the character U+{char:04X} (a control character or an invalid byte)"
        raise MissionError([Problem(file, line, col, message)]) from None
    except yaml.YAMLError as exc:
        raise MissionError([Problem(file, 1, 1, f"YAML error: {exc}")]) from None
    except RecursionError:
        raise MissionError([Problem(file, 1, 1, "the document is nested too deeply")]) from None
    except ValueError as exc:  # a scalar YAML resolves but Python cannot hold (an integer of 5,000 digits)
        raise MissionError([Problem(file, 1, 1, f"a value cannot be read: {exc}")]) from None
    finally:
        if loader is not None:
            loader.dispose()
    return data, smap
