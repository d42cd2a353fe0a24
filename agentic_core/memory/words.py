"""BM25 ranking of a query's words over the store's FTS5 table.

Alone (no embedder), every word counts but those in more than :data:`~agentic_core.memory.ranking.COMMON` of the
documents, unless all are. Beside a vector ranking (hybrid search) a word found in more than
:data:`HYBRID_MAX_DOCS` documents is not ranked either, and no word at all when every one is: BM25 must score every
document holding a word to rank it, so a frequent word costs thousands of rows for a list whose fused weight
barely moves the vector ranking (it was most of a hybrid query's time at 50,000 memories).

>>> import sqlite3
>>> conn = sqlite3.connect(":memory:")
>>> _ = conn.execute("CREATE VIRTUAL TABLE store_words USING fts5(text)")
>>> _ = conn.execute("CREATE VIRTUAL TABLE store_words_vocab USING fts5vocab(store_words, 'row')")
>>> _ = conn.execute("CREATE TABLE store_items(id INTEGER PRIMARY KEY)")
>>> for i in range(1, 101):
...     _ = conn.execute("INSERT INTO store_items(id) VALUES (?)", (i,))
...     text = "crowd ramp" if i == 7 else "crowd"
...     _ = conn.execute("INSERT INTO store_words(rowid, text) VALUES (?, ?)", (i, text))
>>> ranker = WordRanker(conn, hybrid_max_docs=50)
>>> ranker.rank("crowd ramp", 10)[0], ranker.rank("crowd", 10)[0][:3]
([7], [1, 2, 3])
>>> ranker.rank("crowd ramp", 10, hybrid=True)[0], ranker.rank("crowd", 10, hybrid=True)[0]
([7], [])
"""

from __future__ import annotations

import sqlite3

from .ranking import COMMON, match_expression, words

HYBRID_MAX_DOCS = 1000
"""Beside a vector ranking, a word in more documents than this is not ranked by BM25."""
Ranked = tuple[list[int], dict[int, float]]


class WordRanker:
    """Ids best matching a query's words (BM25, best first) and each one's score (minus FTS5's rank)."""

    def __init__(self, conn: sqlite3.Connection, *, hybrid_max_docs: int = HYBRID_MAX_DOCS) -> None:
        self.conn = conn
        self.hybrid_max_docs = hybrid_max_docs
        self._frequency: dict[str, int] = {}  # documents per word, kept until the store writes (:meth:`stale`)
        self._total: int | None = None

    def stale(self) -> None:
        """The store wrote: forget the counts (FTS5 counts a frequent word's documents one by one: seconds' worth
        over a day of queries)."""
        self._frequency.clear()
        self._total = None

    def _counts(self, terms: list[str]) -> tuple[dict[str, int], int]:
        missing = [t for t in terms if t not in self._frequency]
        if missing:
            marks = ",".join("?" * len(missing))
            found = dict(self.conn.execute(f"SELECT term, doc FROM store_words_vocab WHERE term IN ({marks})",
                                           missing).fetchall())  # fmt: skip
            self._frequency.update({t: int(found.get(t, 0)) for t in missing})
        if self._total is None:
            self._total = int(self.conn.execute("SELECT count(*) FROM store_items").fetchone()[0])
        return {t: self._frequency[t] for t in terms if self._frequency[t]}, self._total

    def rank(self, query: str, top: int, *, hybrid: bool = False) -> Ranked:
        """The ``top`` best ids; ``hybrid``: only rare words count (see the module docs)."""
        terms = words(query)
        if not terms:
            return [], {}
        frequency, total = self._counts(terms)
        total = total if frequency else 0
        if hybrid:
            terms = [t for t in terms if frequency.get(t, 0) <= self.hybrid_max_docs]
        expression = match_expression(terms, frequency, total) if terms else None
        if expression is None:
            return [], {}
        rows = self.conn.execute(
            "SELECT rowid, rank FROM store_words WHERE store_words MATCH ? ORDER BY rank LIMIT ?", (expression, top)
        ).fetchall()
        return [int(r[0]) for r in rows], {int(r[0]): -float(r[1]) for r in rows}


__all__ = ["COMMON", "HYBRID_MAX_DOCS", "WordRanker"]
