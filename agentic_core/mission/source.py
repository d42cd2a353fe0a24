"""Reading mission files with positions: every problem found later can name its file, line and column.

PyYAML's composed node tree carries marks; we keep the position of every value (and key) by its path in the
document, so a pydantic error at ``steps.2.args.alt_m`` becomes ``mission.yaml:14:15: ...``.
"""

from __future__ import annotations

import contextlib
import gc
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import yaml

from agentic_core.contracts.problems import LocatedProblem, ProblemsError
from agentic_core.contracts.yaml_positions import KeyIndex, node_position, position_at

from .step_bound import (
    EVENT_COUNT_FROM,
    count_over,
    first_past_bounds,
    first_past_size,
    over_message,
)

Path = tuple[str | int, ...]


Problem = LocatedProblem
"""One thing wrong with a mission file, printed as ``file:line:col: message``."""


class MissionError(ProblemsError):
    """A mission that cannot be flown; ``problems`` holds every problem found in it, in file order."""


@dataclass
class SourceMap:
    """Where each value (and each mapping key) of a document starts, by path; 1-based lines and columns.

    Positions are looked up in the composed YAML tree only when a problem needs one, so loading a valid
    mission pays nothing for them: :func:`load_document` keeps the ``text``, not the tree (tens of thousands of
    objects for a large mission), and the tree is composed again the first time a position is asked for.
    ``problems`` holds what was wrong but did not stop loading (a duplicate key); validation reports them with
    everything else it finds."""

    file: str
    root: yaml.Node | None = None
    problems: list[Problem] = field(default_factory=list)
    text: str | None = None  # the document ``root`` is composed from when it is first needed
    _keys: KeyIndex = field(default_factory=dict, init=False, repr=False)  # ``root``'s mapping keys, once looked up

    def tree(self) -> yaml.Node | None:
        """The composed document (None for an empty one, or a map with neither tree nor text)."""
        if self.root is None and self.text is not None:
            self.root = _compose_for_positions(self.text)
        return self.root

    def at(self, path: Path, *, key: bool = False) -> tuple[int, int]:
        """The position of ``path``, or of its nearest ancestor that exists (a missing field: its parent)."""
        root = self.tree()
        return position_at(root, path, key=key, index=self._keys) if root is not None else (1, 1)

    def problem(self, path: Path, message: str, *, key: bool = False) -> Problem:
        line, col = self.at(path, key=key)
        return Problem(self.file, line, col, message)


ALIAS_BUDGET = 100_000
"""How many values YAML aliases and merge keys may repeat in one document: a few kilobytes of nested aliases
("billion laughs") would otherwise expand to billions of values."""


@dataclass
class _Walk:
    """The state of building one document: the nodes being built (an alias inside itself), the collections built
    once already (a second visit is an alias), the values aliases may still repeat, and merged-mapping sizes."""

    smap: SourceMap
    active: set[int] = field(default_factory=set)
    built: set[int] = field(default_factory=set)
    left: int = ALIAS_BUDGET
    sizes: dict[int, int] = field(default_factory=dict)

    def charge(self, node: yaml.Node, count: int) -> None:
        self.left -= count
        if self.left < 0:
            line, col = node_position(node)
            message = (
                f"YAML aliases repeat more than {ALIAS_BUDGET:,} values (the anchor here is expanded again and again: "
                "a 'billion laughs' document); write the values out or use fewer nested aliases"
            )
            raise MissionError([Problem(self.smap.file, line, col, message)])

    def merged_size(self, node: yaml.MappingNode) -> int:
        """The number of entries ``node`` has once its merge keys are flattened, without flattening it."""
        stack: list[tuple[yaml.Node, bool]] = [(node, False)]
        while stack:
            current, ready = stack.pop()
            if id(current) in self.sizes or not isinstance(current, yaml.MappingNode | yaml.SequenceNode):
                continue
            merged = (
                [v for k, v in current.value if k.tag == _MERGE_TAG] if isinstance(current, yaml.MappingNode) else []
            )
            parts = [n for v in merged for n in (v.value if isinstance(v, yaml.SequenceNode) else [v])]
            if not ready:
                stack.append((current, True))
                stack.extend((p, False) for p in parts if id(p) not in self.active)
                continue
            own = len(current.value) - len(merged)
            self.sizes[id(current)] = own + sum(self.sizes.get(id(p), 0) for p in parts)
        return self.sizes.get(id(node), 0)


def _build(node: yaml.Node, smap: SourceMap, loader: yaml.SafeLoader, walk: _Walk) -> Any:
    """Construct the value of ``node``, noting duplicate keys, refusing aliases that refer to themselves and
    charging every value an alias repeats to the document's alias budget.

    Values that are plain strings (most of a mission) are taken straight off their node, without a call per
    value; PyYAML's constructors run only for the other scalars (numbers, booleans, null, ...)."""
    if isinstance(node, yaml.ScalarNode):
        return _scalar(node, loader, smap)
    active = walk.active
    if id(node) in active:
        line, col = node_position(node)
        raise MissionError(
            [Problem(smap.file, line, col, "a YAML alias refers to itself: the document would be infinite")]
        )
    if id(node) in walk.built:
        walk.charge(node, len(node.value))
    walk.built.add(id(node))
    active.add(id(node))
    out: Any
    if isinstance(node, yaml.MappingNode):
        out = _mapping(node, smap, loader, walk)
    else:
        out = [
            item.value
            if item.tag == _STR_TAG and isinstance(item, yaml.ScalarNode)
            else _build(item, smap, loader, walk)
            for item in node.value
        ]
    active.discard(id(node))
    return out


def _mapping(node: yaml.MappingNode, smap: SourceMap, loader: yaml.SafeLoader, walk: _Walk) -> dict[Any, Any]:
    """The dict of a mapping node. Duplicate keys (among the keys as written: merged ones may be overridden) are
    noted in ``smap.problems``, their positions looked up only then; merge keys (``<<: *defaults``) are
    flattened by PyYAML, only when the mapping has one (or a ``=`` key, which flattening turns into text), and
    only when what they would add fits the alias budget."""
    seen: dict[str, yaml.Node] = {}
    flatten = False
    for key_node, _ in node.value:
        tag = key_node.tag
        if tag in (_MERGE_TAG, _VALUE_TAG):
            flatten = True
            if tag == _MERGE_TAG:
                continue
        if not isinstance(key_node, yaml.ScalarNode):
            continue
        key = key_node.value
        first = seen.get(key)
        if first is not None:
            line, col = node_position(key_node)
            message = f"duplicate key {key!r} (first at line {node_position(first)[0]}); the last wins"
            smap.problems.append(Problem(smap.file, line, col, message))
        seen[key] = key_node
    if flatten:
        walk.charge(node, max(0, walk.merged_size(node) - len(node.value)))
        loader.flatten_mapping(node)
    out: dict[Any, Any] = {}
    for key_node, value_node in node.value:
        if not isinstance(key_node, yaml.ScalarNode):
            key = None
        elif key_node.tag == _STR_TAG:
            key = key_node.value
        else:
            key = loader.construct_object(key_node)
        if key is None or isinstance(key, list | dict):
            line, col = node_position(key_node)
            raise MissionError([Problem(smap.file, line, col, "a mapping key must be a plain name or number")])
        if value_node.tag == _STR_TAG and isinstance(value_node, yaml.ScalarNode):
            out[key] = value_node.value
        else:
            out[key] = _build(value_node, smap, loader, walk)
    return out


def _scalar(node: yaml.ScalarNode, loader: yaml.SafeLoader, smap: SourceMap) -> Any:
    if node.tag == _STR_TAG:
        return node.value  # no constructor needed
    construct = loader.yaml_constructors.get(node.tag)
    value = construct(loader, node) if construct is not None else loader.construct_object(node)
    if node.tag == _FLOAT_TAG and math.isinf(value) and not _SPECIAL_FLOAT.fullmatch(node.value):
        line, col = node_position(node)
        message = f"{node.value} is out of range for a number (beyond ±1.8e308); write a smaller number"
        raise MissionError([Problem(smap.file, line, col, message)])
    return value


_STR_TAG = "tag:yaml.org,2002:str"
_INT_TAG = "tag:yaml.org,2002:int"
_FLOAT_TAG = "tag:yaml.org,2002:float"
_DECIMAL_INT = re.compile(r"[-+]?(?:0|[1-9][0-9]*)")
_DECIMAL_FLOAT = re.compile(r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?")
_SPECIAL_FLOAT = re.compile(r"[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)")


def _number_tag(tag: str, value: str) -> str:
    """The tag of a plain scalar with YAML 1.2's numbers (as JSON writes them), not YAML 1.1's: ``1:30``,
    ``0x1F``, ``012`` and ``1_000`` are text (PyYAML would read 90, 31, 10 and 1000, silently), and ``1.0e12``
    is a number (PyYAML would read text, its exponent having no sign)."""
    if tag == _INT_TAG and not _DECIMAL_INT.fullmatch(value):
        return _STR_TAG
    if tag == _FLOAT_TAG and not (_DECIMAL_FLOAT.fullmatch(value) or _SPECIAL_FLOAT.fullmatch(value)):
        return _STR_TAG
    if tag == _STR_TAG and _DECIMAL_FLOAT.fullmatch(value):
        return _FLOAT_TAG
    return tag


_MERGE_TAG = "tag:yaml.org,2002:merge"
_VALUE_TAG = "tag:yaml.org,2002:value"  # a plain ``=`` key; flatten_mapping makes it a string


_SafeLoader: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml when present: 10x faster


class _Loader(_SafeLoader):  # type: ignore[misc,valid-type]  # a base class chosen at run time
    """The safe loader, resolving the tag of each distinct plain scalar once per document, numbers as YAML 1.2
    writes them (:func:`_number_tag`).

    libyaml's composer calls the (Python) resolver for every scalar, which tries a few regular expressions each
    time; a mission repeats the same keys and values (``id``, ``action``, ``args``, ``30``) hundreds of times.
    Without path resolvers (the safe loader has none) a plain scalar's tag depends on its text alone, and a
    quoted one is always a string."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._tags: dict[str, str] = {}

    def resolve(self, kind: type[yaml.Node], value: Any, implicit: tuple[bool, bool]) -> str:
        if kind is yaml.ScalarNode and not self.yaml_path_resolvers:
            if not implicit[0]:
                return _STR_TAG
            tag = self._tags.get(value)
            if tag is None:
                tag = self._tags[value] = _number_tag(str(super().resolve(kind, value, implicit)), value)
            return tag
        return str(super().resolve(kind, value, implicit))


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


@contextlib.contextmanager
def _cyclic_gc_paused() -> Iterator[None]:
    """Pause Python's cyclic garbage collector while a document is composed and turned into data.

    The composed tree is tens of thousands of objects (a node and two marks per value) that live only while
    the document is read and hold no reference cycle (the one exception, an alias inside itself, is refused;
    the collector frees it later). With the collector on, every 700 new objects start a collection that walks
    the young ones again, promoting the tree from generation to generation until a full collection walks the
    whole heap: several milliseconds for a large mission, for nothing. Freed by reference counting once the
    document is read, the tree is never seen by the collector. The collector is the process's: other threads
    see their collections put off by those milliseconds, no more. A collector that was off stays off."""
    if not gc.isenabled():
        yield
        return
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


def _parse(text: str, smap: SourceMap) -> Any:
    """Compose ``text`` and build its data; the tree is dropped on return (``smap`` composes it again if a
        position is needed). A mission past the bound on steps is refused first, and a large text with a list past its
    bound before it is built."""
    if len(text) >= EVENT_COUNT_FROM:
        counter = _Loader(text)
        try:
            over = first_past_bounds(counter)
        finally:
            counter.dispose()
        if over is not None:
            raise MissionError([Problem(smap.file, *over)])
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise MissionError([Problem(smap.file, 1, 1, "the file is empty; a mission needs plan_id, goal and steps")])
        data = _build(node, smap, loader, _Walk(smap))
    finally:
        loader.dispose()
    over_data = count_over(data)
    if over_data is not None:
        raise MissionError([smap.problem(over_data[0], over_message(over_data[1]))])
    too_big = first_past_size(data)
    if too_big is not None:
        raise MissionError([smap.problem(*too_big)])
    return data


def _compose_for_positions(text: str) -> yaml.Node | None:
    """The tree of a document that loaded, as loading left it: merge keys flattened, as :func:`_mapping` does
    (flattening a mapping is idempotent and flattens the mappings merged into it first, so the order in which
    mappings are visited, once each, does not matter). No Python recursion: a document nested as deeply as
    loading allowed is composed at any depth of the caller's stack."""
    loader = _Loader(text)
    try:
        root: yaml.Node | None = loader.get_single_node()
        stack = [root] if root is not None else []
        seen: set[int] = set()
        while stack:
            node = stack.pop()
            if id(node) in seen:
                continue
            seen.add(id(node))
            if isinstance(node, yaml.MappingNode):
                if any(key.tag in (_MERGE_TAG, _VALUE_TAG) for key, _ in node.value):
                    loader.flatten_mapping(node)
                stack.extend(value for _, value in node.value)
            elif isinstance(node, yaml.SequenceNode):
                stack.extend(node.value)
        return root
    finally:
        loader.dispose()


def load_document(text: str, file: str) -> tuple[Any, SourceMap]:
    """Parse YAML (or JSON, which is YAML) into plain data and its source map; raises :class:`MissionError`."""
    smap = SourceMap(file, text=text)
    try:
        with _cyclic_gc_paused():
            data = _parse(text, smap)
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
    except MissionError:  # already positioned (an empty file, a list as a key): not to be wrapped again
        raise
    except ValueError as exc:  # a scalar YAML resolves but Python cannot hold (an integer of 5,000 digits)
        raise MissionError([Problem(file, 1, 1, f"a value cannot be read: {exc}")]) from None
    return data, smap
