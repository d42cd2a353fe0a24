"""What the store holds and returns, and the operations ``batch`` takes: the shapes of LangGraph's Store API.

An :class:`Item` is one value under ``(namespace, key)``; a :class:`SearchItem` adds the search score. Both carry
our one addition, :class:`Invalidation`: a memory found wrong is marked so, with a reason, and stays readable.

>>> from datetime import datetime, timezone
>>> t = datetime(2026, 1, 1, tzinfo=timezone.utc)
>>> Item(value={"a": 1}, key="k", namespace=("n",), created_at=t, updated_at=t).dict()["namespace"]
['n']
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any, Literal, NamedTuple

from agentic_core.contracts.errors import InputError

NamespacePath = tuple[str, ...]
"""A namespace pattern for ``list_namespaces``; a label ``"*"`` matches any one label."""


class InvalidNamespaceError(InputError):
    """A namespace is empty, or one of its labels is not a non-empty string free of ``.`` and NUL."""


@dataclass(frozen=True)
class Invalidation:
    """Why and when a memory stopped being believed, and who said so; the memory itself is kept."""

    reason: str
    at: datetime
    by: str = ""


class Item:
    """One stored value: ``value``, ``key``, ``namespace``, ``created_at``, ``updated_at`` (UTC), as LangGraph's."""

    __slots__ = ("created_at", "invalidated", "key", "namespace", "updated_at", "value")

    def __init__(
        self,
        *,
        value: dict[str, Any],
        key: str,
        namespace: tuple[str, ...],
        created_at: datetime,
        updated_at: datetime,
        invalidated: Invalidation | None = None,
    ) -> None:
        self.value = value
        self.key = key
        self.namespace = tuple(namespace)
        self.created_at = created_at
        self.updated_at = updated_at
        self.invalidated = invalidated

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Item):
            return NotImplemented
        return self.dict() == other.dict()

    def __hash__(self) -> int:
        return hash((self.namespace, self.key))

    def dict(self) -> dict[str, Any]:
        """The item as JSON-ready data (timestamps as ISO text)."""
        out: dict[str, Any] = {
            "namespace": list(self.namespace),
            "key": self.key,
            "value": self.value,
            "created_at": self.created_at.isoformat(),
            "updated_at": self.updated_at.isoformat(),
        }
        if self.invalidated is not None:
            inv = self.invalidated
            out["invalidated"] = {"reason": inv.reason, "at": inv.at.isoformat(), "by": inv.by}
        return out

    def __repr__(self) -> str:
        return f"{type(self).__name__}({', '.join(f'{k}={v!r}' for k, v in self.dict().items())})"


class SearchItem(Item):
    """An item found by ``search``; ``score`` is the cosine similarity, or the BM25 relevance without vectors."""

    __slots__ = ("score",)

    def __init__(self, *, score: float | None = None, **fields: Any) -> None:
        super().__init__(**fields)
        self.score = score

    def dict(self) -> dict[str, Any]:
        return {**super().dict(), "score": self.score}


class GetOp(NamedTuple):
    """Read one item."""

    namespace: tuple[str, ...]
    key: str
    refresh_ttl: bool = True


class SearchOp(NamedTuple):
    """Find items under a namespace prefix, filtered, ranked by ``query`` when given."""

    namespace_prefix: tuple[str, ...]
    filter: dict[str, Any] | None = None
    limit: int = 10
    offset: int = 0
    query: str | None = None
    refresh_ttl: bool = True


class MatchCondition(NamedTuple):
    """A namespace pattern anchored at the start (``prefix``) or the end (``suffix``)."""

    match_type: Literal["prefix", "suffix"]
    path: NamespacePath


class ListNamespacesOp(NamedTuple):
    """List the namespaces that hold items, matched, truncated to ``max_depth`` and paged."""

    match_conditions: tuple[MatchCondition, ...] | None = None
    max_depth: int | None = None
    limit: int = 100
    offset: int = 0


class PutOp(NamedTuple):
    """Write ``value`` (``None`` deletes); ``index`` is False (no index), None (the store's fields) or paths."""

    namespace: tuple[str, ...]
    key: str
    value: dict[str, Any] | None
    index: Literal[False] | list[str] | None = None  # type: ignore[assignment]  # LangGraph's name, over tuple.index
    ttl: float | None = None


Op = GetOp | SearchOp | ListNamespacesOp | PutOp
Result = Item | list[SearchItem] | list[tuple[str, ...]] | None
