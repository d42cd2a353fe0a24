"""How big a tool's output is as JSON, found without serialising it: the executor's bound on a tool's answer.

:func:`measure` walks the value once, adding up the length its compact JSON text would have, and stops as soon as
the sum passes the limit, so a 200 MB answer costs a few steps, not a copy. Strings count by their UTF-8 bytes
plus their quotes (escapes aside), ``bytes`` by their length. It also refuses what is not JSON data and could
not be bounded without running it (a generator, an arbitrary object whose ``repr`` could be anything), and cycles.

>>> measure({"blob": "A" * 10}, limit=100)
OutputSize(size=22, problem=None)
>>> measure({"blob": "A" * 10_000_000}, limit=1024).problem
'too large: 10000012 bytes of JSON or more, over the limit of 1024'
>>> measure({"rows": (n for n in range(3))}, limit=1024).problem
'not JSON data: $.rows is a generator'
"""

from __future__ import annotations

import dataclasses
import datetime
import decimal
import enum
import os
import pathlib
import uuid
from collections.abc import Iterator, Mapping
from typing import Any, NamedTuple

from pydantic import BaseModel

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.json_depth import MAX_JSON_DEPTH

DEFAULT_MAX_OUTPUT_BYTES = 1024 * 1024
"""A tool's largest answer, as compact JSON: 1 MiB, far above any tool's real answer, far below what hurts."""
MAX_OUTPUT_ENV = "AGENTIC_UAV_MAX_TOOL_OUTPUT_BYTES"
MAX_OUTPUT_DEPTH = MAX_JSON_DEPTH
"""Lists and objects nested deeper than this are refused, as in JSON input: later readers walk them recursively."""
_CHUNK = 65_536  # characters encoded at a time to count a non-ASCII string's UTF-8 bytes
_SMALL_SCALARS = (datetime.date, datetime.time, datetime.timedelta, decimal.Decimal, uuid.UUID, pathlib.PurePath)


class OutputSize(NamedTuple):
    """The output's JSON size counted so far, and why it is refused (None: within the limit)."""

    size: int
    problem: str | None


def configured_limit(environ: Mapping[str, str] | None = None) -> int:
    """The default bound: :data:`MAX_OUTPUT_ENV` when set (a positive whole number of bytes), else 1 MiB.

    >>> configured_limit({}), configured_limit({MAX_OUTPUT_ENV: "2048"})
    (1048576, 2048)
    """
    text = (os.environ if environ is None else environ).get(MAX_OUTPUT_ENV, "").strip()
    if not text:
        return DEFAULT_MAX_OUTPUT_BYTES
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value <= 0:
        raise InputError(f"{MAX_OUTPUT_ENV}={text!r}: expected a positive whole number of bytes")
    return value


def _text_size(text: str, budget: int) -> int:
    """``text``'s UTF-8 length plus its quotes, counted in chunks and no further than just past ``budget``."""
    if text.isascii():
        return len(text) + 2
    size, n = 2, len(text)
    for start in range(0, n, _CHUNK):
        size += len(text[start : start + _CHUNK].encode("utf-8", "surrogatepass"))
        if size > budget:
            return size + (n - start - _CHUNK if n > start + _CHUNK else 0)  # the rest counted one byte each
    return size


def _scalar_size(value: Any, budget: int) -> int | None:
    """The JSON length of a scalar, or None when ``value`` is not one."""
    if value is None or value is True:
        return 4
    if value is False:
        return 5
    if isinstance(value, str):
        return _text_size(value, budget)
    if isinstance(value, int):
        return _int_size(value)
    if isinstance(value, float):
        return len(repr(value))
    if isinstance(value, bytes | bytearray):
        return len(value) + 2
    if isinstance(value, memoryview):
        return value.nbytes + 2
    if isinstance(value, enum.Enum):
        return _scalar_size(value.value, budget)
    if isinstance(value, _SMALL_SCALARS):
        return len(str(value)) + 2
    if type(value).__module__ == "numpy":  # without importing numpy: a scalar prints short, an array by its bytes
        return int(value.nbytes) * 2 + 2 if getattr(value, "ndim", 0) else len(str(value))
    return None


def _int_size(value: int) -> int:
    """Its digits: printed when it is small, else from its bit length, maybe one over (printing a huge int is the
    cost to avoid)."""
    bits = value.bit_length()
    return len(str(value)) if bits <= 64 else bits * 30103 // 100000 + 1 + (value < 0)


def _kind(value: Any) -> str:
    name = type(value).__name__
    return f"an {name}" if name[:1].lower() in "aeiou" else f"a {name}"


def _members(node: Any) -> Iterator[tuple[Any, Any]] | None:
    """An iterator over a container's (key, item) pairs (an int key for an array's), or None for a non-container.
    Never a list of them: a container of ten million items is walked only as far as the limit."""
    if isinstance(node, Mapping):
        return iter(node.items())
    if isinstance(node, list | tuple | set | frozenset):
        return enumerate(node)
    if isinstance(node, BaseModel):
        return ((name, getattr(node, name, None)) for name in type(node).model_fields)
    if dataclasses.is_dataclass(node) and not isinstance(node, type):
        return ((f.name, getattr(node, f.name, None)) for f in dataclasses.fields(node))
    return None


def _path(keys: list[Any]) -> str:
    def part(key: Any) -> str:
        if isinstance(key, int) and not isinstance(key, bool):
            return f"[{key}]"
        text = str(key) if isinstance(key, str | int | float | bool) or key is None else _kind(key)
        return f".{text[:40]}..." if len(text) > 40 else f".{text}"

    text = "$" + "".join(part(key) for key in keys)
    return text if len(text) <= 120 else f"{text[:60]}...{text[-57:]}"


def measure(value: Any, limit: int) -> OutputSize:
    """The JSON size of ``value``, with the reason it is refused: over ``limit`` bytes, not JSON data, circular,
    or nested deeper than :data:`MAX_OUTPUT_DEPTH`. Each step adds at least one byte, so the walk takes at most
    ``limit`` steps whatever the value holds."""
    size = 0
    keys: list[Any] = []  # the path to the member being sized
    walking: list[tuple[int, bool, Iterator[tuple[Any, Any]]]] = []  # open containers: id, is an array, members
    open_ids: set[int] = set()  # a container met again inside itself is a cycle
    node, key, has_key = value, None, False
    while True:
        kind = type(node)
        scalar = None if kind is dict or kind is list else _scalar_size(node, limit - size)
        if scalar is not None:
            size += scalar
        else:
            members = iter(node.items()) if kind is dict else enumerate(node) if kind is list else _members(node)
            where = [*keys, key] if has_key else keys
            if members is None:
                return OutputSize(size, f"not JSON data: {_path(where)} is {_kind(node)}")
            if id(node) in open_ids:
                return OutputSize(size, f"not JSON data: {_path(where)} contains itself")
            if len(walking) >= MAX_OUTPUT_DEPTH:
                return OutputSize(size, f"nested more than {MAX_OUTPUT_DEPTH} levels deep at {_path(where)}")
            size += 2
            if has_key:
                keys.append(key)
            open_ids.add(id(node))
            walking.append((id(node), isinstance(node, list | tuple | set | frozenset), members))
        if size > limit:
            return _too_large(size, limit)
        while walking:  # the members of the innermost open container; plain scalars sized here, in one loop
            _, is_array, members = walking[-1]
            for key, node in members:
                if is_array:
                    size += 1
                elif type(key) is str and key.isascii():
                    size += len(key) + 4
                else:
                    size += _key_size(key, limit - size)
                kind = type(node)
                if kind is str and node.isascii():
                    size += len(node) + 2
                elif kind is float:
                    size += len(repr(node))
                elif kind is int:
                    size += _int_size(node)
                elif node is None or node is True:
                    size += 4
                elif node is False:
                    size += 5
                else:
                    has_key = True
                    break  # a container, or a scalar of another kind: the outer loop sizes it
                if size > limit:
                    return _too_large(size, limit)
            else:
                closed, _, _ = walking.pop()
                open_ids.discard(closed)
                if walking:
                    keys.pop()
                continue
            break
        else:
            return OutputSize(size, None)


def _too_large(size: int, limit: int) -> OutputSize:
    return OutputSize(size, f"too large: {size} bytes of JSON or more, over the limit of {limit}")


def _key_size(key: Any, budget: int) -> int:
    """An object member's key as JSON with its colon and comma (``"key":`` and ``,``)."""
    if isinstance(key, str):
        return _text_size(key, budget) + 2
    scalar = _scalar_size(key, budget)
    return (scalar if scalar is not None else 2) + 4


__all__ = [
    "DEFAULT_MAX_OUTPUT_BYTES",
    "MAX_OUTPUT_DEPTH",
    "MAX_OUTPUT_ENV",
    "OutputSize",
    "configured_limit",
    "measure",
]
