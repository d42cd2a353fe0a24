"""Hybrid search leaves frequent words to the vectors: a rare word still brings its memory up, a query of only
frequent words still finds by meaning, and BM25 alone (no embedder) still ranks by frequent words."""

from __future__ import annotations

from agentic_core.memory import SqliteStore
from agentic_core.memory.words import WordRanker


def toy_embed(texts: list[str]) -> list[list[float]]:
    """A letter-count embedder: texts sharing letters point the same way."""
    return [[float(t.count(c)) + 0.01 for c in "abcde"] for t in texts]


def crowded(hybrid: bool = True, embed: bool = True) -> SqliteStore:
    index = {"dims": 5, "embed": toy_embed, "fields": ["t"], "hybrid": hybrid} if embed else {"fields": ["t"]}
    store = SqliteStore(index=index)
    for i in range(60):
        store.put(("h",), f"k{i}", {"t": f"crowd {'abba' if i % 2 else 'ceed'}"})
    store.put(("h",), "rare", {"t": "crowd ceed qqq"})
    store._words = WordRanker(store.conn, hybrid_max_docs=10)  # "crowd" (61 documents) is frequent here
    return store


def test_a_rare_word_still_brings_its_memory_up_beside_the_vectors() -> None:
    """The vectors point at the 'abba' memories; the one word only 'rare' holds brings it first."""
    assert crowded(hybrid=False).search(("h",), query="crowd abba qqq", limit=1)[0].key != "rare"
    assert crowded().search(("h",), query="crowd abba qqq", limit=1)[0].key == "rare"


def test_a_query_of_frequent_words_is_ranked_by_the_vectors_alone() -> None:
    store = crowded()
    found = store.search(("h",), query="crowd abba", limit=5)
    assert len(found) == 5 and all("abba" in (i.value["t"]) for i in found)


def test_without_an_embedder_frequent_words_are_still_ranked() -> None:
    store = crowded(embed=False)
    found = store.search(("h",), query="crowd", limit=3)
    assert len(found) == 3 and all(i.score is not None for i in found)


def test_the_word_counts_kept_between_queries_are_forgotten_when_the_store_writes() -> None:
    store = crowded()
    assert store._words.rank("qqq", 10, hybrid=True)[0]  # one memory holds it: rare, ranked
    for i in range(20):
        store.put(("h",), f"more{i}", {"t": "qqq"})
    assert store._words.rank("qqq", 10, hybrid=True)[0] == []  # 21 now: frequent, left to the vectors
    store.delete(("h",), "rare")
    assert store._words.rank("crowd", 10)[0]  # BM25 alone still ranks what is left
