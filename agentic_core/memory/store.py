"""``SqliteStore``: LangGraph's Store API on the standard library's sqlite3, with no server.

Words are searched with FTS5 (BM25); with an embedder in the ``index`` config, vectors too (float32 BLOBs, held
in a numpy matrix for scoring), and the two rankings fused (reciprocal rank fusion). TTL in minutes as
LangGraph's; a memory may be *invalidated* with a reason and stays readable (``get``, ``history``); searches skip
invalidated memories unless asked. One connection behind a lock: safe to share between threads.

>>> store = SqliteStore(":memory:")
>>> store.put(("incidents", "jamarat"), "c1", {"text": "heat stroke casualty at the east ramp"})
>>> [i.key for i in store.search(("incidents",), query="casualty heat")]
['c1']
>>> store.invalidate(("incidents", "jamarat"), "c1", "was a resting pilgrim", by="operator")
>>> store.search(("incidents",)), store.get(("incidents", "jamarat"), "c1").invalidated.reason
([], 'was a resting pilgrim')
"""

from __future__ import annotations

import asyncio
import json
import sqlite3
import threading
import time
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Literal, TypedDict

import numpy as np

from agentic_core.contracts.errors import InputError

from . import filters, schema
from .embed.base import Embedder, resolve
from .items import GetOp, Item, ListNamespacesOp, MatchCondition, Op, PutOp, Result, SearchItem, SearchOp
from .namespaces import check_labels, check_writable, decode, encode, matches, under
from .paths import texts_at, tokens
from .prefilter import Prefilter
from .vectors import VectorIndex
from .words import WordRanker

FETCH = 256  # candidate rows read per query while filling a page
FUSE_DEPTH = 1000  # how deep each ranking goes at least (4 x the page when that is more)


class IndexConfig(TypedDict, total=False):
    """LangGraph's index config: ``dims``, ``embed`` (a model name or function), ``fields`` (paths, default
    ``["$"]``); ours: ``hybrid`` (fuse with BM25 words, default True)."""

    dims: int
    embed: Any
    fields: list[str] | None
    hybrid: bool


class TTLConfig(TypedDict, total=False):
    """LangGraph's TTL config: ``default_ttl`` minutes, ``refresh_on_read`` (default True)."""

    default_ttl: float | None
    refresh_on_read: bool
    sweep_interval_minutes: int | None


def _words(value: Mapping[str, Any], paths: list[str]) -> str:
    """The text FTS5 indexes: the strings at ``paths`` (``$``: every string in the value, not its JSON)."""
    if paths == ["$"]:
        found: list[str] = []
        stack: list[Any] = [value]
        while stack:
            node = stack.pop()
            if isinstance(node, str):
                found.append(node)
            elif isinstance(node, dict):
                stack.extend(reversed(list(node.values())))
            elif isinstance(node, list):
                stack.extend(reversed(node))
        return "\n".join(found)
    return "\n".join(t for p in paths for t in texts_at(value, p))


class SqliteStore:
    """A persistent store with LangGraph's methods (``put get search delete list_namespaces batch`` and their
    ``a``-prefixed async twins). Pass a path, ``":memory:"`` or an open connection."""

    supports_ttl = True

    def __init__(
        self,
        conn: str | Path | sqlite3.Connection = ":memory:",
        *,
        index: IndexConfig | Mapping[str, Any] | None = None,
        ttl: TTLConfig | Mapping[str, Any] | None = None,
        history: bool = True,
    ) -> None:
        self.index_config: dict[str, Any] | None = dict(index) if index else None
        self.ttl_config: dict[str, Any] | None = dict(ttl) if ttl else None
        self.keep_history = history
        self.embedder: Embedder | None = None
        self.fields: list[str] = ["$"]
        self.hybrid = True
        if self.index_config is not None:
            self.fields = list(self.index_config.get("fields") or ["$"])
            for path in self.fields:
                if path != "$":
                    tokens(path)
            self.hybrid = bool(self.index_config.get("hybrid", True))
            if self.index_config.get("embed") is not None:
                self.embedder = resolve(self.index_config["embed"])
        self._lock = threading.RLock()
        if isinstance(conn, sqlite3.Connection):
            self.conn = conn
        else:
            try:
                self.conn = sqlite3.connect(str(conn), check_same_thread=False, isolation_level=None)
                if str(conn) != ":memory:":
                    self.conn.execute("PRAGMA journal_mode=WAL")
            except sqlite3.Error as exc:
                raise InputError(f"{conn}: cannot open the memory store ({exc})") from None
        with self._lock:  # executescript commits by itself: no transaction around it
            dims = self.index_config.get("dims") if self.index_config else None
            schema.create(self.conn, self.embedder.name if self.embedder else None, dims)
        self._vectors = VectorIndex(self.conn, self._lock)
        self._prefilter = Prefilter(self.conn, self._lock)
        self._words = WordRanker(self.conn)
        with self._lock:
            has_ttl = self.conn.execute("SELECT 1 FROM store_items WHERE ttl_minutes IS NOT NULL LIMIT 1").fetchone()
        self._ttl_seen = has_ttl is not None  # no item ever had a TTL: reads need not write

    @property
    def embedding(self) -> str:
        """What ranks a query here: ``"<model> + BM25"``, ``"<model>"`` or ``"BM25 only (no embedder)"``."""
        if self.embedder is None:
            return "BM25 only (no embedder)"
        return f"{self.embedder.name} + BM25" if self.hybrid else self.embedder.name

    @contextmanager
    def _tx(self) -> Iterator[None]:
        if self.conn.in_transaction:
            yield
            return
        self.conn.execute("BEGIN IMMEDIATE")
        try:
            yield
        except BaseException:
            self.conn.execute("ROLLBACK")
            raise
        self.conn.execute("COMMIT")

    # --- LangGraph's Store API ---
    def get(self, namespace: tuple[str, ...], key: str, *, refresh_ttl: bool | None = None) -> Item | None:
        """The item at ``(namespace, key)`` (invalidated ones included), or None."""
        result = self.batch([GetOp(check_labels(namespace), str(key), self._refresh(refresh_ttl))])[0]
        return result if isinstance(result, Item) else None

    def search(
        self,
        namespace_prefix: tuple[str, ...],
        /,
        *,
        query: str | None = None,
        filter: dict[str, Any] | None = None,
        limit: int = 10,
        offset: int = 0,
        refresh_ttl: bool | None = None,
        include_invalidated: bool = False,
    ) -> list[SearchItem]:
        """Items under ``namespace_prefix`` passing ``filter``; ranked by ``query`` when given, else oldest first."""
        op = SearchOp(check_labels(namespace_prefix), filter, limit, offset, query, self._refresh(refresh_ttl))
        with self._lock:
            return self._search(op, include_invalidated)

    def put(
        self,
        namespace: tuple[str, ...],
        key: str,
        value: Mapping[str, Any],
        index: Literal[False] | list[str] | None = None,
        *,
        ttl: float | object | None = ...,
    ) -> None:
        """Write ``value`` at ``(namespace, key)``; ``ttl`` minutes (default: the TTL config's)."""
        minutes = (self.ttl_config or {}).get("default_ttl") if ttl is ... else ttl
        if minutes is not None and not isinstance(minutes, int | float):
            raise InputError(f"put {key!r}: ttl is minutes (a number) or None, got {minutes!r}")
        if not isinstance(value, Mapping):
            raise InputError(f"put {key!r}: a value is a mapping with string keys, got {type(value).__name__}")
        self.batch([PutOp(check_writable(namespace), str(key), dict(value), index, minutes)])

    def delete(self, namespace: tuple[str, ...], key: str) -> None:
        """Remove the item (its history stays). Prefer :meth:`invalidate` for a memory found wrong."""
        self.batch([PutOp(check_labels(namespace), str(key), None)])

    def list_namespaces(
        self,
        *,
        prefix: tuple[str, ...] | None = None,
        suffix: tuple[str, ...] | None = None,
        max_depth: int | None = None,
        limit: int = 100,
        offset: int = 0,
    ) -> list[tuple[str, ...]]:
        """Namespaces holding items, sorted, matched by ``prefix``/``suffix`` (``"*"`` any label), cut to
        ``max_depth`` labels (duplicates merged), then paged."""
        conditions = [MatchCondition("prefix", check_labels(prefix))] if prefix else []
        conditions += [MatchCondition("suffix", check_labels(suffix))] if suffix else []
        result = self.batch([ListNamespacesOp(tuple(conditions), max_depth, limit, offset)])[0]
        return result if isinstance(result, list) else []  # type: ignore[return-value]

    def batch(self, ops: Iterable[Op]) -> list[Result]:
        """Run operations in order, writes in one transaction; results in the order of ``ops``."""
        ops = list(ops)
        embedded = self._embed_puts([op for op in ops if isinstance(op, PutOp)])
        results: list[Result] = []
        with self._lock, self._tx():
            for op in ops:
                if isinstance(op, GetOp):
                    results.append(self._get(check_labels(op.namespace), op.key, op.refresh_ttl))
                elif isinstance(op, SearchOp):
                    results.append(self._search(op, False))
                elif isinstance(op, ListNamespacesOp):
                    results.append(self._list(op))
                elif isinstance(op, PutOp):
                    self._put(op, embedded.get((op.namespace, op.key)))
                    results.append(None)
                else:
                    raise InputError(f"store batch: unknown operation {type(op).__name__}")
        return results

    # --- async twins (run in a worker thread; the store is thread-safe) ---
    async def abatch(self, ops: Iterable[Op]) -> list[Result]:
        return await asyncio.to_thread(self.batch, list(ops))

    async def aget(self, namespace: tuple[str, ...], key: str, *, refresh_ttl: bool | None = None) -> Item | None:
        return await asyncio.to_thread(lambda: self.get(namespace, key, refresh_ttl=refresh_ttl))

    async def asearch(self, namespace_prefix: tuple[str, ...], /, **kwargs: Any) -> list[SearchItem]:
        return await asyncio.to_thread(lambda: self.search(namespace_prefix, **kwargs))

    async def aput(self, namespace: tuple[str, ...], key: str, value: Mapping[str, Any], *a: Any, **kw: Any) -> None:
        await asyncio.to_thread(lambda: self.put(namespace, key, value, *a, **kw))

    async def adelete(self, namespace: tuple[str, ...], key: str) -> None:
        await asyncio.to_thread(self.delete, namespace, key)

    async def alist_namespaces(self, **kwargs: Any) -> list[tuple[str, ...]]:
        return await asyncio.to_thread(lambda: self.list_namespaces(**kwargs))

    # --- ours: invalidation, history, TTL sweep ---
    def invalidate(self, namespace: tuple[str, ...], key: str, reason: str, *, by: str = "") -> None:
        """Mark a memory as no longer believed, with why and who; it stays readable, searches skip it."""
        if not reason.strip():
            raise InputError(f"invalidate {key!r}: say why (reason is empty)")
        ns = encode(check_labels(namespace))
        at = schema.now().isoformat()
        with self._lock, self._tx():
            cur = self.conn.execute(
                "UPDATE store_items SET invalid_reason = ?, invalid_at = ?, invalid_by = ? WHERE ns = ? AND key = ?",
                (reason, at, by, ns, str(key)),
            )
            if cur.rowcount == 0:
                raise InputError(f"invalidate: no memory {key!r} in namespace {decode(ns)!r}")
            self._log(ns, str(key), "invalidate", None, at, reason, by)

    def history(self, namespace: tuple[str, ...], key: str) -> list[dict[str, Any]]:
        """Every write, invalidation and deletion of ``(namespace, key)``, oldest first."""
        with self._lock:
            rows = self.conn.execute(
                "SELECT event, value, at, reason, by FROM store_history WHERE ns = ? AND key = ? ORDER BY id",
                (encode(check_labels(namespace)), str(key)),
            ).fetchall()
        return [
            {"event": e, "value": None if v is None else json.loads(v), "at": at, "reason": r, "by": b}
            for e, v, at, r, b in rows
        ]

    def sweep_ttl(self) -> int:
        """Delete the items whose TTL has passed; how many."""
        with self._lock, self._tx():
            ids = [r[0] for r in self.conn.execute("SELECT id FROM store_items WHERE expires_at <= ?", (time.time(),))]
            for item_id in ids:
                self._erase(item_id)
        return len(ids)

    def close(self) -> None:
        with self._lock:
            self.conn.close()

    # --- internals (called under the lock) ---
    def _refresh(self, refresh_ttl: bool | None) -> bool:
        if refresh_ttl is not None:
            return refresh_ttl
        return bool((self.ttl_config or {}).get("refresh_on_read", True))

    def _log(self, ns: str, key: str, event: str, value: str | None, at: str, reason: str = "", by: str = "") -> None:
        if self.keep_history:
            self.conn.execute(
                "INSERT INTO store_history (ns, key, event, value, at, reason, by) VALUES (?, ?, ?, ?, ?, ?, ?)",
                (ns, key, event, value, at, reason or None, by or None),
            )

    def _live(self) -> tuple[str, float]:
        return "(expires_at IS NULL OR expires_at > ?)", time.time()

    def _touch(self, ids: list[int]) -> None:
        if ids:
            marks = ",".join("?" * len(ids))
            self.conn.execute(
                f"UPDATE store_items SET expires_at = ? + ttl_minutes * 60 WHERE ttl_minutes IS NOT NULL "
                f"AND id IN ({marks})",
                (time.time(), *ids),
            )

    def _get(self, namespace: tuple[str, ...], key: str, refresh: bool) -> Item | None:
        live, t = self._live()
        row = self.conn.execute(
            f"SELECT {schema.COLUMNS} FROM store_items WHERE ns = ? AND key = ? AND {live}",
            (encode(namespace), key, t),
        ).fetchone()
        if row is None:
            return None
        if refresh and self._ttl_seen:
            self._touch([row[0]])
        return schema.item(row)

    def _embed_puts(self, puts: list[PutOp]) -> dict[tuple[tuple[str, ...], str], list[tuple[str, Any]]]:
        """Each put's (path, vector) pairs, computed before the lock is taken (embedding is slow)."""
        if self.embedder is None:
            return {}
        wanted: list[tuple[tuple[tuple[str, ...], str], str, str]] = []
        for op in puts:
            if op.value is None or op.index is False:
                continue
            for path in self.fields if op.index is None else list(op.index):
                found = texts_at(op.value, path)
                wanted += [((op.namespace, op.key), path if len(found) == 1 else f"{path}.{i}", t) for i, t in
                           enumerate(found)]  # fmt: skip
        matrix = self.embedder.embed([text for _, _, text in wanted]) if wanted else None
        out: dict[tuple[tuple[str, ...], str], list[tuple[str, Any]]] = {}
        for row, (item, path, _) in enumerate(wanted):
            out.setdefault(item, []).append((path, matrix[row] if matrix is not None else None))
        return out

    def _put(self, op: PutOp, vectors: list[tuple[str, Any]] | None) -> None:
        ns, key = encode(check_labels(op.namespace)), str(op.key)
        at = schema.now().isoformat()
        old = self.conn.execute("SELECT id FROM store_items WHERE ns = ? AND key = ?", (ns, key)).fetchone()
        if op.value is None:
            if old is not None:
                self._erase(old[0])
                self._log(ns, key, "delete", None, at)
            return
        check_writable(op.namespace)
        text = schema.to_json(op.value, f"put {decode(ns)!r} {key!r}")
        expires = None if op.ttl is None else time.time() + float(op.ttl) * 60
        self._ttl_seen = self._ttl_seen or op.ttl is not None
        if old is None:
            item_id = self.conn.execute(
                "INSERT INTO store_items (ns, key, value, created_at, updated_at, ttl_minutes, expires_at) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                (ns, key, text, at, at, op.ttl, expires),
            ).lastrowid
        else:
            item_id = old[0]
            self.conn.execute(
                "UPDATE store_items SET value = ?, updated_at = ?, ttl_minutes = ?, expires_at = ?, "
                "invalid_reason = NULL, invalid_at = NULL, invalid_by = NULL WHERE id = ?",
                (text, at, op.ttl, expires, item_id),
            )
            self.conn.execute("DELETE FROM store_words WHERE rowid = ?", (item_id,))
            self.conn.execute("DELETE FROM store_vectors WHERE item_id = ?", (item_id,))
        if op.index is not False:
            paths = self.fields if op.index is None else list(op.index)
            self.conn.execute("INSERT INTO store_words (rowid, body) VALUES (?, ?)", (item_id, _words(op.value, paths)))
        for path, vec in vectors or []:
            blob = np.asarray(vec, dtype=np.float32).tobytes()
            self.conn.execute("INSERT INTO store_vectors (item_id, path, vec) VALUES (?, ?, ?)", (item_id, path, blob))
        self._vectors.stale()
        self._prefilter.stale()
        self._words.stale()
        self._log(ns, key, "put", text, at)

    def _erase(self, item_id: int) -> None:
        self.conn.execute("DELETE FROM store_items WHERE id = ?", (item_id,))
        self.conn.execute("DELETE FROM store_words WHERE rowid = ?", (item_id,))
        self.conn.execute("DELETE FROM store_vectors WHERE item_id = ?", (item_id,))
        self._vectors.stale()
        self._prefilter.stale()
        self._words.stale()

    def _list(self, op: ListNamespacesOp) -> list[tuple[str, ...]]:
        live, t = self._live()
        found = [decode(r[0]) for r in self.conn.execute(f"SELECT DISTINCT ns FROM store_items WHERE {live}", (t,))]
        found = [ns for ns in found if all(matches(c, ns) for c in op.match_conditions or ())]
        if op.max_depth is not None:
            found = list({ns[: op.max_depth] for ns in found})
        return sorted(found)[op.offset : op.offset + op.limit]

    def _search(self, op: SearchOp, include_invalidated: bool) -> list[SearchItem]:
        prefix = check_labels(op.namespace_prefix)
        wanted = filters.check(op.filter)
        if op.limit < 0 or op.offset < 0:
            raise InputError(f"search: limit and offset cannot be negative (limit={op.limit}, offset={op.offset})")
        scores: dict[int, float] = {}
        need = op.offset + op.limit
        allowed = self._prefilter.allowed(wanted, prefix)
        top = max(FUSE_DEPTH, 4 * need)
        ranked = self._ranked(op.query, prefix, scores, top, allowed) if op.query else []
        rest: list[int] | None = None  # None: every row, oldest first
        if allowed is not None:
            rest = allowed.tolist()
            inside = set(rest)
            ranked = [i for i in ranked if i in inside]
        live, t = self._live()
        where = f"{live}" + ("" if include_invalidated else " AND invalid_reason IS NULL")
        if prefix:
            where += " AND (ns = ? OR substr(ns, 1, ?) = ?)"
        args: tuple[Any, ...] = (t, encode(prefix), len(encode(prefix)) + 1, encode(prefix) + ".") if prefix else (t,)
        kept: list[tuple[int, SearchItem]] = []
        for row in self._candidates(ranked, rest, where, args):
            if need == 0 or len(kept) >= need:
                break
            found = schema.item(row, scores.get(row[0]), search=True)
            if under(found.namespace, prefix) and filters.accepts(wanted, found.value):
                kept.append((int(row[0]), found))  # type: ignore[arg-type]
        page = kept[op.offset : need]
        if op.refresh_ttl and self._ttl_seen:
            self._touch([item_id for item_id, _ in page])
        return [found for _, found in page]

    def _candidates(
        self, ranked: list[int], rest: list[int] | None, where: str, args: tuple[Any, ...]
    ) -> Iterator[tuple[Any, ...]]:
        """Rows in rank order: the ranked ids, then the rest by age (``rest``, or every row when None), a chunk of
        :data:`FETCH` at a time."""
        seen = set(ranked)
        for ids in (ranked, None if rest is None else [i for i in rest if i not in seen]):
            for start in range(0, len(ids or []), FETCH):
                chunk = (ids or [])[start : start + FETCH]
                marks = ",".join("?" * len(chunk))
                rows = self.conn.execute(
                    f"SELECT {schema.COLUMNS} FROM store_items WHERE id IN ({marks}) AND {where}", (*chunk, *args)
                ).fetchall()
                by_id = {r[0]: r for r in rows}
                yield from (by_id[i] for i in chunk if i in by_id)
        if rest is not None:
            return
        last = 0
        while True:
            rows = self.conn.execute(
                f"SELECT {schema.COLUMNS} FROM store_items WHERE id > ? AND {where} ORDER BY id LIMIT {FETCH}",
                (last, *args),
            ).fetchall()
            if not rows:
                return
            last = rows[-1][0]
            yield from (r for r in rows if r[0] not in seen)

    def _ranked(self, query: str, prefix: tuple[str, ...], scores: dict[int, float], top: int, allowed: Any = None
                ) -> list[int]:  # fmt: skip
        """The ``top`` ids most relevant to ``query``: vector ranking (scores = cosine) fused with BM25 words, or
        either alone. Past them, candidates come oldest first: the ranking is exact for the first ``top``, which
        is at least four times the page asked for. Words are ranked over the whole store (the namespace is
        checked when rows are read), so that FTS5 can rank them without a join; beside vectors, only rare words
        (:mod:`.words`)."""
        from .ranking import fuse

        if self.embedder is None:
            by_words, word_scores = self._words.rank(query, top)
            scores.update(word_scores)
            return by_words
        q = self.embedder.embed([query])[0]
        by_vector = self._vectors.rank(q, prefix, scores, top, allowed)
        by_words = self._words.rank(query, top, hybrid=True)[0] if self.hybrid else []
        if not by_vector or not by_words:
            return by_vector or by_words
        return fuse([by_vector, by_words])
