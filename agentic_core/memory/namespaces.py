"""Namespaces: tuples of labels, checked as LangGraph checks them, stored as text joined by ``.``.

A label may not contain ``.``, so the joined text is unambiguous and a prefix of labels is a prefix of text.

>>> encode(("runs", "r1"))
'runs.r1'
>>> matches(MatchCondition("suffix", ("*", "r1")), ("runs", "r1"))
True
"""

from __future__ import annotations

from collections.abc import Sequence

from .items import InvalidNamespaceError, MatchCondition

RESERVED_ROOT = "langgraph"


def check_labels(namespace: Sequence[object]) -> tuple[str, ...]:
    """The namespace as a tuple of str, or :class:`InvalidNamespaceError` naming the bad label."""
    if not isinstance(namespace, tuple | list):
        raise InvalidNamespaceError(f"a namespace is a tuple of strings, got {type(namespace).__name__}")
    for label in namespace:
        if not isinstance(label, str):
            raise InvalidNamespaceError(f"namespace {tuple(namespace)!r}: label {label!r} is not a string")
        if not label:
            raise InvalidNamespaceError(f"namespace {tuple(namespace)!r}: a label is empty")
        if "." in label or "\x00" in label:
            raise InvalidNamespaceError(f"namespace {tuple(namespace)!r}: label {label!r} contains '.' or NUL")
    return tuple(str(label) for label in namespace)


def check_writable(namespace: Sequence[object]) -> tuple[str, ...]:
    """A namespace an item may be written under: non-empty, valid labels, not rooted at ``langgraph``."""
    labels = check_labels(namespace)
    if not labels:
        raise InvalidNamespaceError("a namespace to write under cannot be empty")
    if labels[0] == RESERVED_ROOT:
        raise InvalidNamespaceError(f"namespace {labels!r}: the root label {RESERVED_ROOT!r} is reserved")
    return labels


def encode(namespace: tuple[str, ...]) -> str:
    return ".".join(namespace)


def decode(text: str) -> tuple[str, ...]:
    return tuple(text.split("."))


def under(namespace: tuple[str, ...], prefix: tuple[str, ...]) -> bool:
    """Whether ``namespace`` lies under ``prefix`` (whole labels; the empty prefix holds everything)."""
    return namespace[: len(prefix)] == prefix


def matches(condition: MatchCondition, namespace: tuple[str, ...]) -> bool:
    """Whether ``namespace`` matches a prefix or suffix pattern, ``"*"`` standing for any one label."""
    path = condition.path
    if len(namespace) < len(path):
        return False
    part = namespace[: len(path)] if condition.match_type == "prefix" else namespace[len(namespace) - len(path) :]
    return all(p == "*" or p == n for p, n in zip(path, part, strict=True))
