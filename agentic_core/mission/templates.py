"""``${...}`` argument templates in mission steps: finding them in nested arguments (to check them when a mission
is loaded) and filling them in from a scope (when a step runs). Each ``${...}`` holds one
:class:`.expressions.Expression`; ``$${`` stands for a literal ``${``.

>>> render({"alt_m": "${params.alt + 5}", "note": "found ${steps.scan.persons} people"},
...        {"params": {"alt": 40}, "steps": {"scan": {"persons": 3}}})
{'alt_m': 45, 'note': 'found 3 people'}
>>> [(path, expr.source) for path, expr in find_templates({"args": {"points": [1, "${params.p}"]}})]
[('args.points[1]', 'params.p')]
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from typing import Any

from .expressions import Expression, ExpressionError, _describe, _parse_cached, _quote


def _template_end(text: str, start: int) -> int:
    """Index of the '}' closing the template whose expression starts at ``start`` (brackets, quotes aware), or -1."""
    depth, quote, i = 0, "", start
    while i < len(text):
        char = text[i]
        if quote:
            i += char == "\\"
            quote = "" if char == quote else quote
        elif char in "'\"":
            quote = char
        elif char in "([{":
            depth += 1
        elif char in ")]}":
            if char == "}" and depth == 0:
                return i
            depth -= 1
        i += 1
    return -1


@functools.lru_cache(maxsize=1024)
def _split(text: str) -> tuple[str | Expression, ...]:
    """A string as literal pieces and parsed ``${...}`` expressions; ``$${`` is a literal ``${``."""
    parts: list[str | Expression] = []
    literal, i = "", 0
    while (start := text.find("${", i)) >= 0:
        if start > 0 and text[start - 1] == "$":
            literal, i = literal + text[i : start - 1] + "${", start + 2
            continue
        end = _template_end(text, start + 2)
        if end < 0:
            raise ExpressionError(
                f"unterminated template at column {start} in {_quote(text)}: no closing '}}'", text, start
            )
        if literal or start > i:
            parts.append(literal + text[i:start])
        parts.append(_parse_cached(text[start + 2 : end]))
        literal, i = "", end + 1
    if literal or i < len(text):
        parts.append(literal + text[i:])
    return tuple(parts)


def _child(path: str, key: Any) -> str:
    if isinstance(key, str) and key.isidentifier():
        return f"{path}.{key}" if path else key
    return f"{path}[{key!r}]"


def _at(path: str, exc: ExpressionError) -> ExpressionError:
    return ExpressionError(f"{exc.message} (template at {path or 'the top level'})", exc.source, exc.col)


_LEAVES = (int, float, type(None))


def _template_strings(value: Any, keys: tuple[Any, ...], out: list[tuple[tuple[Any, ...], str]]) -> None:
    """Append to ``out`` the strings holding ``${`` in a nested value, with the keys (and list indexes) leading
    to each. The path text is written later, only for those; numbers, booleans and None are passed over without
    a call, or a (slow) check against the Mapping ABC."""
    if isinstance(value, str):
        if "${" in value:
            out.append((keys, value))
        return
    items: Iterable[tuple[Any, Any]]
    if isinstance(value, _LEAVES):
        return
    if isinstance(value, Mapping):
        items = value.items()
    elif isinstance(value, list | tuple):
        items = enumerate(value)
    else:
        return
    for key, item in items:
        if isinstance(item, str):
            if "${" in item:
                out.append(((*keys, key), item))
        elif not isinstance(item, _LEAVES):
            _template_strings(item, (*keys, key), out)


def find_templates(value: Any) -> list[tuple[str, Expression]]:
    """Every ``${...}`` in a nested dict/list/str as (path like ``args.points[2]``, parsed expression)."""
    found: list[tuple[str, Expression]] = []
    strings: list[tuple[tuple[Any, ...], str]] = []
    _template_strings(value, (), strings)
    for keys, text in strings:
        path = functools.reduce(_child, keys, "")  # args.points[2].lat (an index is written as a key's repr is)
        try:
            found.extend((path, part) for part in _split(text) if isinstance(part, Expression))
        except ExpressionError as exc:
            raise _at(path, exc) from None
    return found


def _render_text(text: str, scope: Mapping[str, Any], path: str) -> Any:
    try:
        parts = _split(text) if "${" in text else (text,)
        if len(parts) == 1 and isinstance(parts[0], Expression):
            return parts[0].evaluate(scope)
        return "".join(part if isinstance(part, str) else _format(part, scope) for part in parts)
    except ExpressionError as exc:
        raise _at(path, exc) from None


def _format(expr: Expression, scope: Mapping[str, Any]) -> str:
    value = expr.evaluate(scope)
    try:
        return str(value)
    except Exception as exc:
        raise ExpressionError(
            f"cannot format the value of {_quote(expr.source)}: {_describe(exc)}", expr.source
        ) from exc


def _render(value: Any, scope: Mapping[str, Any], path: str) -> Any:
    if isinstance(value, str):
        return _render_text(value, scope, path)
    if isinstance(value, Mapping):
        return {key: _render(item, scope, _child(path, key)) for key, item in value.items()}
    if isinstance(value, list | tuple):
        items = [_render(item, scope, f"{path}[{i}]") for i, item in enumerate(value)]
        return items if isinstance(value, list) else tuple(items)
    return value


def render(value: Any, scope: Mapping[str, Any]) -> Any:
    """A copy of ``value`` with templates filled in: a string that is exactly ``${expr}`` becomes the raw value,
    text around templates gives a string (values via ``str``); dicts, lists and tuples are rebuilt, others kept."""
    return _render(value, scope, "")


__all__ = ["find_templates", "render"]
