"""Ranking for hybrid search: words by FTS5's BM25, vectors by cosine, fused by reciprocal rank fusion.

Reciprocal rank fusion scores a document ``sum(1 / (k + rank))`` over the lists it appears in (rank from 1), so
neither list's raw scores need to be comparable; ``k = 60`` is the value of its authors' experiments.

>>> fuse([[3, 1, 2], [1, 4]])
[1, 3, 4, 2]
"""

from __future__ import annotations

import re
from collections.abc import Sequence

RRF_K = 60
_WORD = re.compile(r"\w+", re.UNICODE)


def fuse(rankings: Sequence[Sequence[int]], k: int = RRF_K) -> list[int]:
    """Ids ordered by their fused score (ties: first seen first)."""
    score: dict[int, float] = {}
    for ranking in rankings:
        for rank, doc in enumerate(ranking, start=1):
            score[doc] = score.get(doc, 0.0) + 1.0 / (k + rank)
    return sorted(score, key=lambda d: -score[d])


def match_expression(query: str) -> str | None:
    """An FTS5 MATCH expression for a free-text query: any of its words, each quoted (no operators get through).

    >>> match_expression('heat "stroke" OR near(x)')
    '"heat" OR "stroke" OR "OR" OR "near" OR "x"'
    >>> match_expression("¿?") is None
    True
    """
    words = _WORD.findall(query)
    return " OR ".join(f'"{w}"' for w in words) if words else None
