"""Ranking for hybrid search: words by FTS5's BM25, vectors by cosine, fused by reciprocal rank fusion.

Reciprocal rank fusion scores a document ``sum(1 / (k + rank))`` over the lists it appears in (rank from 1), so
neither list's raw scores need to be comparable; ``k = 60`` is the value of its authors' experiments.

>>> fuse([[3, 1, 2], [1, 4]])
[1, 3, 4, 2]
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

RRF_K = 60
_WORD = re.compile(r"\w+", re.UNICODE)


def fuse(rankings: Sequence[Sequence[int]], k: int = RRF_K) -> list[int]:
    """Ids ordered by their fused score (ties: first seen first)."""
    score: dict[int, float] = {}
    for ranking in rankings:
        for rank, doc in enumerate(ranking, start=1):
            score[doc] = score.get(doc, 0.0) + 1.0 / (k + rank)
    return sorted(score, key=lambda d: -score[d])


COMMON = 0.2
"""A word in more than this share of the documents is left out of a query's BM25 ranking: its inverse document
frequency is near zero, so it barely moves the ranking, yet ranking by it means scoring most of the store."""


def words(query: str) -> list[str]:
    """The query's words, lower-cased, each once, in order."""
    return list(dict.fromkeys(w.lower() for w in _WORD.findall(query)))


def match_expression(terms: Sequence[str], frequency: Mapping[str, int] | None = None, total: int = 0) -> str | None:
    """An FTS5 MATCH expression: any of ``terms``, each quoted (no operators get through), without those in more
    than :data:`COMMON` of ``total`` documents (``frequency``: documents per term) unless all are.

    >>> match_expression(words('heat "stroke" OR near(x)'))
    '"heat" OR "stroke" OR "or" OR "near" OR "x"'
    >>> match_expression(["the", "heat"], {"the": 90, "heat": 3}, total=100)
    '"heat"'
    >>> match_expression(words("¿?")) is None
    True
    """
    if not terms:
        return None
    counts = frequency or {}
    rare = [t for t in terms if counts.get(t, 0) <= COMMON * total] if total else list(terms)
    kept = rare or [min(terms, key=lambda t: counts.get(t, 0))]
    return " OR ".join(f'"{t}"' for t in kept)
