"""The bounds on a mission's size: at most :data:`MAX_STEPS` steps, nested and trigger steps included, no list
longer than :data:`MAX_LIST_ITEMS` (a polygon's points) and at most :data:`MAX_VALUES` values in all, each refused
with the file, line and column of the first step, item or value past it.

A real mission has tens of steps and polygons of tens of points; a file of hundreds of thousands (30 MB of
``hover``, of one fence's points, or of many polygons' points) would take gigabytes to check. A large text is
counted from the parser's events before it is built, stopping at the first step, item or value past a bound, so
such a file is refused in the time it takes to read that far; any text is counted again once built (aliases can
repeat a step in a few bytes), and the polygons' contracts hold their own bound.

>>> import yaml
>>> text = "steps:\\n" + "".join(f"  - {{id: s{i}, action: rtl}}\\n" for i in range(MAX_STEPS + 1))
>>> first_past_bounds(yaml.SafeLoader(text))[:2]
(1002, 5)
>>> next(step_paths({"steps": [{"id": "a"}, {"id": "b", "then": [{"id": "c"}]}]}))
('steps', 0)
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import yaml

from agentic_core.contracts.mission_values import MAX_POINTS
from agentic_core.contracts.policy_graph import MAX_STEPS, NESTED_STEP_LISTS

Path = tuple[str | int, ...]

MAX_LIST_ITEMS = MAX_POINTS
"""The longest list a mission file may hold: a polygon's points bound it (the steps' own bound is lower)."""

LIST_OVER_MESSAGE = (
    f"a list in a mission has at most {MAX_LIST_ITEMS:,} items (a polygon at most {MAX_POINTS:,} points); this is "
    f"item {MAX_LIST_ITEMS + 1:,}"
)

MAX_VALUES = 100_000
"""The most values (numbers and texts; a mapping's keys not counted) a mission may hold: 1,000 steps of a dozen
values (12,000) beside four polygons of 10,000 points (20,000 each) fit."""

VALUES_OVER_MESSAGE = f"a mission holds at most {MAX_VALUES:,} values; this is value {MAX_VALUES + 1:,}"

EVENT_COUNT_FROM = 1 << 20
"""Texts of at least this many characters are counted from events before they are built: a mission of 1,000
steps is well under it, so an ordinary mission is parsed once."""


def over_message(count_at_least: int | None = None) -> str:
    """What a mission past the bound is told, at its first step past it."""
    return (
        f"a mission has at most {MAX_STEPS:,} steps, nested and trigger steps included; this is step "
        f"{MAX_STEPS + 1:,}{f' of {count_at_least:,}' if count_at_least else ''} (split the mission, or use a "
        "repeat for a patrol)"
    )


def step_paths(data: Any) -> Iterator[Path]:
    """The document path of every step of parsed mission data, in the order written (each step before the steps
    nested in it; the plan's steps and the triggers' as their keys come)."""
    if not isinstance(data, dict):
        return
    lists: list[tuple[Path, Any]] = []
    for key, value in data.items():  # in the order written
        if key == "steps":
            lists.append((("steps",), value))
        elif key == "triggers" and isinstance(value, list):
            lists += [(("triggers", t, "steps"), tr.get("steps")) for t, tr in enumerate(value) if isinstance(tr, dict)]
    for base, steps in lists:
        if not isinstance(steps, list):
            continue
        stack: list[tuple[Path, Iterator[tuple[int, Any]]]] = [(base, enumerate(steps))]
        while stack:
            where, items = stack[-1]
            item = next(items, None)
            if item is None:
                stack.pop()
                continue
            i, step = item
            yield (*where, i)
            if isinstance(step, dict):
                for key in reversed(NESTED_STEP_LISTS):
                    body = step.get(key)
                    if isinstance(body, list):
                        stack.append(((*where, i, key), enumerate(body)))


def count_over(data: Any) -> tuple[Path, int] | None:
    """The path of the first step past the bound and the number of steps, or None within it."""
    first: Path | None = None
    count = 0
    for path in step_paths(data):
        count += 1
        if count == MAX_STEPS + 1:
            first = path
    return (first, count) if first is not None else None


def first_past_size(data: Any) -> tuple[Path, str] | None:
    """The path of the first list item past :data:`MAX_LIST_ITEMS`, or of the first value past :data:`MAX_VALUES`,
    in the order written, in parsed mission data, and what is wrong there; None within both. What aliases repeat
    is counted as often as it is repeated (the loader copies it: the alias budget bounds the copies)."""
    values = 0
    stack: list[tuple[Path, Iterator[tuple[Any, Any]], Any]] = []

    def open_(path: Path, value: Any) -> None:
        items = iter(value.items()) if isinstance(value, dict) else enumerate(value[:MAX_LIST_ITEMS])
        stack.append((path, items, value))

    if isinstance(data, dict | list):
        open_((), data)
    while stack:
        path, items, value = stack[-1]
        item = next(items, None)
        if item is None:
            stack.pop()
            if isinstance(value, list) and len(value) > MAX_LIST_ITEMS:
                return (*path, MAX_LIST_ITEMS), LIST_OVER_MESSAGE
            continue
        key, child = item
        if isinstance(child, dict | list):
            open_((*path, key), child)
            continue
        values += 1
        if values > MAX_VALUES:
            return (*path, key), VALUES_OVER_MESSAGE
    return None


class _Open:
    """An open collection while reading events: a mapping or a sequence, what it is in a mission (``root``,
    ``step``, ``trigger``, ``steps`` (a list of steps), ``triggers`` or ``other``) and, for a mapping, the key of
    the value being read (None while a key is expected)."""

    __slots__ = ("items", "key", "mapping", "role")

    def __init__(self, mapping: bool, role: str) -> None:
        self.mapping, self.role = mapping, role
        self.key: Any = None
        self.items = 0


_LISTS = {("root", "steps"): "steps", ("root", "triggers"): "triggers", ("trigger", "steps"): "steps"}
_LISTS.update({("step", key): "steps" for key in ("steps", "then", "else")})
_ITEMS = {"steps": "step", "triggers": "trigger"}


def first_past_bounds(loader: yaml.SafeLoader) -> tuple[int, int, str] | None:
    """The 1-based line and column of the first step, list item or value past a bound, and what is wrong there,
    read from ``loader``'s events (consumed: the loader is done with after), or None when the document is within
    them. Values are the scalars that are not a mapping's keys; what an alias repeats is not seen here."""
    stack: list[_Open] = []
    count = values = 0
    reading_key = False
    while loader.check_event():
        event = loader.get_event()  # type: ignore[no-untyped-call]
        if isinstance(event, yaml.MappingEndEvent | yaml.SequenceEndEvent):
            stack.pop()
            reading_key = bool(stack) and stack[-1].mapping
            continue
        if not isinstance(event, yaml.NodeEvent):
            continue
        parent = stack[-1] if stack else None
        is_key = parent is not None and parent.mapping and reading_key
        if parent is not None and is_key:
            parent.key = event.value if isinstance(event, yaml.ScalarEvent) else None
            role = "other"
            reading_key = False
        elif parent is None:
            role = "root"
        elif parent.mapping:
            role = _LISTS.get((parent.role, parent.key), "other")
            reading_key = True
        else:
            role = _ITEMS.get(parent.role, "other")
            parent.items += 1
            if parent.role == "steps":
                count += 1
                if count > MAX_STEPS:
                    return (*_where(event), over_message())
            if parent.items > MAX_LIST_ITEMS:
                return (*_where(event), LIST_OVER_MESSAGE)
        if parent is not None and not is_key and isinstance(event, yaml.ScalarEvent):
            values += 1
            if values > MAX_VALUES:
                return (*_where(event), VALUES_OVER_MESSAGE)
        if isinstance(event, yaml.CollectionStartEvent):
            mapping = isinstance(event, yaml.MappingStartEvent)
            stack.append(_Open(mapping, role if mapping == (role in ("root", "step", "trigger")) else "other"))
            reading_key = mapping
    return None


def _where(event: yaml.Event) -> tuple[int, int]:
    mark = event.start_mark
    return (mark.line + 1, mark.column + 1) if mark is not None else (1, 1)


__all__ = [
    "EVENT_COUNT_FROM",
    "LIST_OVER_MESSAGE",
    "MAX_LIST_ITEMS",
    "MAX_VALUES",
    "VALUES_OVER_MESSAGE",
    "count_over",
    "first_past_bounds",
    "first_past_size",
    "over_message",
    "step_paths",
]
