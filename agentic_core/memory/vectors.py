"""The store's vectors as one numpy matrix, loaded from SQLite when first needed after a write.

Scoring is a single matrix-vector product over the rows whose namespace lies under the search's prefix; an item
with several vectors (one per indexed text) scores its best.
"""

from __future__ import annotations

import sqlite3
import threading
from typing import Any

import numpy as np

from .namespaces import decode, under


class VectorIndex:
    """Rows of unit vectors with the item id and namespace each belongs to; rebuilt lazily after :meth:`stale`."""

    def __init__(self, conn: sqlite3.Connection, lock: threading.RLock) -> None:
        self.conn = conn
        self.lock = lock
        self._matrix: Any = None
        self._ids: Any = None
        self._codes: Any = None
        self._namespaces: list[tuple[str, ...]] = []

    def stale(self) -> None:
        self._matrix = None

    def _load(self) -> None:
        rows = self.conn.execute(
            "SELECT v.item_id, i.ns, v.vec FROM store_vectors v JOIN store_items i ON i.id = v.item_id ORDER BY v.rowid"
        ).fetchall()
        codes: dict[str, int] = {}
        self._ids = np.fromiter((r[0] for r in rows), dtype=np.int64, count=len(rows))
        self._codes = np.fromiter((codes.setdefault(r[1], len(codes)) for r in rows), dtype=np.int64, count=len(rows))
        self._namespaces = [decode(ns) for ns in codes]
        width = len(rows[0][2]) // 4 if rows else 0
        self._matrix = np.frombuffer(b"".join(r[2] for r in rows), dtype=np.float32).reshape(len(rows), width)

    def rank(self, query: Any, prefix: tuple[str, ...], scores: dict[int, float], top: int, only: Any = None
             ) -> list[int]:  # fmt: skip
        """The ``top`` best item ids under ``prefix`` (about: an item with several vectors counts once), best first;
        fills ``scores`` with each one's cosine similarity. ``only``: the item ids a filter allows (the others are
        not scored at all, so a search near a place costs what its place holds)."""
        with self.lock:
            if self._matrix is None:
                self._load()
            matrix, ids, codes = self._matrix, self._ids, self._codes
            inside = [c for c, ns in enumerate(self._namespaces) if under(ns, prefix)]
        if matrix.shape[0] == 0 or not inside:
            return []
        q = np.asarray(query, dtype=np.float32)
        if q.shape[0] != matrix.shape[1]:
            from agentic_core.contracts.errors import InputError

            raise InputError(f"search: the query has {q.shape[0]} dimensions, the stored vectors {matrix.shape[1]}")
        mask: Any = np.isin(codes, inside) if len(inside) < len(self._namespaces) else slice(None)
        if only is not None:
            allowed = np.isin(ids, only)
            mask = allowed if isinstance(mask, slice) else mask & allowed
        sims = matrix[mask] @ q
        row_ids = ids[mask]
        if sims.shape[0] > top:
            best = np.argpartition(-sims, top)[:top]
            order = best[np.argsort(-sims[best], kind="stable")]
        else:
            order = np.argsort(-sims, kind="stable")
        ordered = row_ids[order]
        _, first = np.unique(ordered, return_index=True)  # an item's best row is its first in rank order
        first.sort()
        ranked: list[int] = ordered[first].tolist()
        scores.update(zip(ranked, sims[order][first].tolist(), strict=True))
        return ranked
