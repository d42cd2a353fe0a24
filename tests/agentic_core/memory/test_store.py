"""What our SqliteStore promises beyond LangGraph's API: it persists, it is thread-safe, it invalidates instead of
erasing, it expires by TTL, it searches words without an embedder, and it refuses bad input with a clear error."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from agentic_core.contracts.errors import InputError
from agentic_core.memory import SqliteStore, near, within_last
from agentic_core.memory.embed import resolve


def toy_embed(texts: list[str]) -> list[list[float]]:
    return [[float(t.count(c)) for c in "abcde"] for t in texts]


def test_items_survive_closing_and_reopening_the_file(tmp_path: Path) -> None:
    path = tmp_path / "m.db"
    first = SqliteStore(path, index={"dims": 5, "embed": toy_embed, "fields": ["t"]})
    first.put(("n",), "k", {"t": "aaa"})
    first.close()
    again = SqliteStore(path, index={"dims": 5, "embed": toy_embed, "fields": ["t"]})
    item = again.get(("n",), "k")
    assert item is not None and item.value == {"t": "aaa"}
    assert again.search(("n",), query="a")[0].score == pytest.approx(1.0)


def test_a_file_indexed_with_other_dimensions_is_refused_by_name(tmp_path: Path) -> None:
    path = tmp_path / "m.db"
    SqliteStore(path, index={"dims": 5, "embed": toy_embed}).close()
    with pytest.raises(InputError, match="dims"):
        SqliteStore(path, index={"dims": 384, "embed": toy_embed})


def test_writers_in_many_threads_lose_nothing(tmp_path: Path) -> None:
    store = SqliteStore(tmp_path / "m.db", index={"dims": 5, "embed": toy_embed, "fields": ["t"]})
    errors: list[BaseException] = []

    def write(worker: int) -> None:
        try:
            for i in range(40):
                store.put(("w", str(worker)), f"k{i}", {"t": "ab" * (i % 5 + 1)})
                store.search(("w",), query="ab", limit=3)
        except BaseException as exc:
            errors.append(exc)

    threads = [threading.Thread(target=write, args=(w,)) for w in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert len(store.search(("w",), limit=1000)) == 240
    assert len(store.list_namespaces(prefix=("w",))) == 6


def test_an_invalidated_memory_stays_readable_with_why_and_its_history() -> None:
    store = SqliteStore()
    store.put(("incidents",), "c1", {"text": "casualty at pillar 3"})
    store.put(("incidents",), "c1", {"text": "casualty at pillar 4"})
    store.invalidate(("incidents",), "c1", "it was a resting pilgrim", by="operator:amal")
    item = store.get(("incidents",), "c1")
    assert item is not None
    assert item.value == {"text": "casualty at pillar 4"}
    assert item.invalidated is not None and item.invalidated.by == "operator:amal"
    assert store.search(("incidents",)) == []
    assert store.search(("incidents",), query="casualty") == []
    assert [i.key for i in store.search(("incidents",), include_invalidated=True)] == ["c1"]
    events = store.history(("incidents",), "c1")
    assert [e["event"] for e in events] == ["put", "put", "invalidate"]
    assert events[0]["value"] == {"text": "casualty at pillar 3"} and events[2]["reason"] == "it was a resting pilgrim"


def test_invalidating_needs_a_reason_and_an_existing_memory() -> None:
    store = SqliteStore()
    store.put(("n",), "k", {"v": 1})
    with pytest.raises(InputError, match="reason"):
        store.invalidate(("n",), "k", "  ")
    with pytest.raises(InputError, match="no memory 'ghost'"):
        store.invalidate(("n",), "ghost", "wrong")


def test_ttl_expires_refreshes_on_read_and_sweeps(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = [1000.0]
    monkeypatch.setattr(time, "time", lambda: clock[0])
    store = SqliteStore(ttl={"default_ttl": 1.0})
    store.put(("t",), "short", {"v": 1})
    store.put(("t",), "forever", {"v": 2}, ttl=None)
    clock[0] += 50
    assert store.get(("t",), "short") is not None  # read at 50 s: refreshed to expire at 110 s
    clock[0] += 50
    assert store.get(("t",), "short", refresh_ttl=False) is not None
    clock[0] += 15
    assert store.get(("t",), "short") is None
    assert [i.key for i in store.search(("t",))] == ["forever"]
    assert store.sweep_ttl() == 1
    assert [e["event"] for e in store.history(("t",), "short")] == ["put"]


def test_without_an_embedder_words_rank_by_bm25_and_the_rest_follow() -> None:
    store = SqliteStore()
    assert store.embedding == "BM25 only (no embedder)"
    store.put(("k",), "crush", {"text": "crowd crush advisory: density above five per square metre"})
    store.put(("k",), "heat", {"text": "heat stroke triage: cool first, then transport"})
    store.put(("k",), "other", {"text": "battery swap procedure"})
    found = store.search(("k",), query="heat stroke", limit=10)
    assert found[0].key == "heat" and found[0].score is not None and found[0].score > 0
    assert {i.key for i in found} == {"crush", "heat", "other"}
    assert found[-1].score is None


@pytest.mark.parametrize("query", ['"', "NEAR(a b", "a OR", "*", "col:umn", "-", "\x00", "𝔥𝔢𝔞𝔱"])
def test_queries_with_fts_syntax_are_words_not_commands(query: str) -> None:
    store = SqliteStore()
    store.put(("k",), "x", {"text": "a b column heat"})
    assert [i.key for i in store.search(("k",), query=query)] == ["x"]


def test_place_and_time_filters() -> None:
    store = SqliteStore()
    jamarat = (21.4206, 39.8728)
    store.put(("i",), "at", {"where": {"lat": jamarat[0], "lon": jamarat[1]}, "t": 5000.0})
    store.put(("i",), "150m", {"where": {"lat": jamarat[0] + 150 / 111_195, "lon": jamarat[1]}, "t": 1000.0})
    store.put(("i",), "far", {"where": {"lat": jamarat[0] + 0.01, "lon": jamarat[1]}, "t": 5000.0})
    store.put(("i",), "nowhere", {"t": 5000.0})
    within = {i.key for i in store.search(("i",), filter={"where": near(*jamarat, 200)})}
    assert within == {"at", "150m"}
    recent = {"where": near(*jamarat, 200), "t": within_last(3600, now=5200.0)}
    assert {i.key for i in store.search(("i",), filter=recent)} == {"at"}


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"filter": {"t": {"$regex": "x"}}}, "unknown operator"),
        ({"filter": {"w": {"$near": {"lat": 1}}}}, "lat, lon and within_m"),
        ({"filter": ["t"]}, "mapping"),
        ({"limit": -1}, "negative"),
    ],
)
def test_bad_searches_are_refused_with_what_is_wrong(kwargs: dict[str, Any], message: str) -> None:
    store = SqliteStore()
    store.put(("n",), "k", {"t": 1})
    with pytest.raises(InputError, match=message):
        store.search(("n",), **kwargs)


@pytest.mark.parametrize("value", [{"x": float("nan")}, {"x": object()}, {1: "int key"}, ["not", "a", "dict"]])
def test_values_that_are_not_json_are_refused_and_nothing_is_written(value: Any) -> None:
    store = SqliteStore()
    with pytest.raises(InputError, match="'k'"):
        store.put(("n",), "k", value)
    assert store.get(("n",), "k") is None and store.list_namespaces() == []


def test_an_emptied_namespace_is_no_longer_listed() -> None:
    store = SqliteStore()
    store.put(("a", "b"), "k", {"v": 1})
    store.delete(("a", "b"), "k")
    assert store.list_namespaces() == []


def test_bad_index_configs_are_refused() -> None:
    with pytest.raises(InputError, match="unknown embedder"):
        SqliteStore(index={"dims": 3, "embed": "no-such-model"})
    with pytest.raises(InputError, match="index path"):
        SqliteStore(index={"dims": 3, "embed": toy_embed, "fields": ["a..b[x"]})


def test_a_query_of_other_dimensions_than_the_vectors_is_refused(tmp_path: Path) -> None:
    store = SqliteStore(index={"dims": 5, "embed": toy_embed})
    store.put(("n",), "k", {"t": "abc"})
    store.embedder = resolve(lambda texts: [[1.0, 0.0]] * len(texts))
    with pytest.raises(InputError, match="dimensions"):
        store.search(("n",), query="abc")


def test_hybrid_fusion_brings_an_exact_word_match_up() -> None:
    """Vectors alone rank 'word' last; fused with BM25, where only 'word' names the query's word, it comes first."""
    docs = {"vec": "abe", "mid": "ab", "word": "cc zebra"}
    rankings = {}
    for hybrid in (False, True):
        store = SqliteStore(index={"dims": 5, "embed": toy_embed, "fields": ["t"], "hybrid": hybrid})
        for key, text in docs.items():
            store.put(("h",), key, {"t": text})
        found = store.search(("h",), query="zebra")
        rankings[hybrid] = [i.key for i in found]
        assert math.isclose(found[[i.key for i in found].index("vec")].score or 0, 1.0, abs_tol=1e-6)
    assert rankings == {False: ["vec", "mid", "word"], True: ["word", "vec", "mid"]}


def test_a_store_that_cannot_be_opened_is_named(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot open the memory store"):
        SqliteStore(tmp_path / "no" / "such" / "dir" / "m.db")
    (tmp_path / "not.db").write_text("this is not a database " * 100)
    with pytest.raises(InputError, match=r"not\.db: cannot open the memory store"):
        SqliteStore(tmp_path / "not.db")


def test_the_numeric_prefilter_never_drops_what_the_exact_check_accepts() -> None:
    """Values stored as text, missing, booleans, nested: the pre-filtered search equals a plain Python filter."""
    store = SqliteStore()
    values: list[dict[str, Any]] = [
        {"t": 5}, {"t": "7"}, {"t": "high"}, {"t": True}, {"t": None}, {}, {"t": 2.5}, {"t": {"x": 9}},
        {"w": {"lat": 21.4133, "lon": 39.8933}}, {"w": {"lat": "21.4134", "lon": "39.8933"}},
        {"w": {"lat": 21.5, "lon": 39.8933}}, {"w": {"lat": 21.4133}}, {"w": [21.4133, 39.8933]},
        {"n": {"deep": {"v": 10}}}, {"n": {"deep": {"v": 1}}},
    ]  # fmt: skip
    for i, v in enumerate(values):
        store.put(("p",), f"k{i}", v)
    from agentic_core.memory.filters import accepts

    for f in [{"t": {"$gt": 3}}, {"t": {"$lte": 5}}, {"t": {"$gte": 2, "$lt": 6}}, {"w": near(21.4133, 39.8933, 50)},
              {"n": {"deep": {"v": {"$gt": 5}}}}, {"t": {"$gt": 3}, "w": near(21.4133, 39.8933, 50)}]:  # fmt: skip
        expected = {f"k{i}" for i, v in enumerate(values) if accepts(f, v)}
        assert {i.key for i in store.search(("p",), filter=f, limit=100)} == expected, f
    assert {i.key for i in store.search(("p",), filter={"t": {"$gt": 3}}, limit=100)} == {"k0", "k1"}


def test_the_prefilter_sees_writes_deletes_and_namespaces() -> None:
    store = SqliteStore()
    store.put(("a",), "x", {"t": 1})
    assert [i.key for i in store.search(("a",), filter={"t": {"$gte": 1}})] == ["x"]
    store.put(("a",), "y", {"t": 2})
    store.put(("b",), "z", {"t": 3})
    assert [i.key for i in store.search(("a",), filter={"t": {"$gte": 1}})] == ["x", "y"]
    store.put(("a",), "x", {"t": 0})
    store.delete(("a",), "y")
    assert store.search(("a",), filter={"t": {"$gte": 1}}) == []
    assert [i.key for i in store.search((), filter={"t": {"$gte": 1}})] == ["z"]


def test_deep_pages_of_a_ranked_search_still_hold_every_item_once() -> None:
    store = SqliteStore(index={"dims": 5, "embed": toy_embed, "fields": ["t"]})
    for i in range(60):
        store.put(("d",), f"k{i}", {"t": "a" * (i % 7 + 1) + "b" * (i % 3)})
    pages = [[i.key for i in store.search(("d",), query="aaa", limit=7, offset=o)] for o in range(0, 70, 7)]
    flat = [k for page in pages for k in page]
    assert len(flat) == 60 and len(set(flat)) == 60
