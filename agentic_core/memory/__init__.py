"""The Learning layer: a persistent store with LangGraph's Store API (:class:`SqliteStore`), offline embeddings,
hybrid search with filters by place and time, and the fleet's memory of past missions.

>>> from agentic_core.memory import SqliteStore
>>> SqliteStore(":memory:").embedding
'BM25 only (no embedder)'
"""

from __future__ import annotations

from .filters import near, within_last
from .items import (
    GetOp,
    Invalidation,
    InvalidNamespaceError,
    Item,
    ListNamespacesOp,
    MatchCondition,
    PutOp,
    SearchItem,
    SearchOp,
)
from .store import IndexConfig, SqliteStore, TTLConfig

__all__ = [
    "GetOp",
    "IndexConfig",
    "InvalidNamespaceError",
    "Invalidation",
    "Item",
    "ListNamespacesOp",
    "MatchCondition",
    "PutOp",
    "SearchItem",
    "SearchOp",
    "SqliteStore",
    "TTLConfig",
    "near",
    "within_last",
]
