"""The Store API, run against LangGraph's ``InMemoryStore`` and our ``SqliteStore``: what a LangGraph user's code
may rely on behaves the same on both. Orders the API leaves open (search without a query) are compared as sets."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from typing import Any

import pytest

WORDS = ("apple", "banana", "cherry", "drone", "heat")


def toy_embed(texts: list[str]) -> list[list[float]]:
    """Counts of five words: deterministic, so both stores rank the same way."""
    return [[float(t.lower().count(w)) for w in WORDS] for t in texts]


StoreFactory = Callable[..., Any]


@pytest.fixture(params=["agentic_core", "langgraph"])
def make_store(request: pytest.FixtureRequest, tmp_path: Any) -> StoreFactory:
    """A function building one implementation's store (with ``index=`` passed through)."""
    if request.param == "langgraph":
        memory = pytest.importorskip("langgraph.store.memory")
        return lambda **kw: memory.InMemoryStore(**kw)
    from agentic_core.memory import SqliteStore

    return lambda **kw: SqliteStore(tmp_path / "store.db", **kw)


def keys(items: list[Any]) -> list[str]:
    return [i.key for i in items]


def test_put_then_get_returns_the_value_with_its_place(make_store: StoreFactory) -> None:
    store = make_store()
    store.put(("users", "u1"), "prefs", {"theme": "dark", "n": [1, 2]})
    item = store.get(("users", "u1"), "prefs")
    assert (item.namespace, item.key, item.value) == (("users", "u1"), "prefs", {"theme": "dark", "n": [1, 2]})
    assert item.updated_at >= item.created_at
    assert item.created_at.tzinfo is not None
    assert store.get(("users", "u1"), "other") is None
    assert store.get(("users",), "prefs") is None


def test_put_over_a_key_replaces_and_delete_removes(make_store: StoreFactory) -> None:
    store = make_store()
    store.put(("a",), "k", {"v": 1})
    first = store.get(("a",), "k")
    store.put(("a",), "k", {"v": 2})
    second = store.get(("a",), "k")
    assert second.value == {"v": 2} and second.updated_at >= first.updated_at
    store.delete(("a",), "k")
    assert store.get(("a",), "k") is None
    store.delete(("a",), "never-there")  # deleting what is not there is not an error
    assert store.search(("a",)) == []


@pytest.mark.parametrize("namespace", [(), ("langgraph", "x"), ("a.b",), ("",), ("ok", 3), ("nul\x00",)], ids=repr)
def test_bad_namespaces_are_refused_on_put(make_store: StoreFactory, namespace: tuple[Any, ...]) -> None:
    store = make_store()
    with pytest.raises(ValueError):
        store.put(namespace, "k", {"v": 1})
    assert store.list_namespaces() == []


def test_a_dotted_label_cannot_reach_a_nested_namespace(make_store: StoreFactory) -> None:
    store = make_store()
    store.put(("a", "b"), "k", {"v": 1})
    with pytest.raises(ValueError):
        store.get(("a.b",), "k")
    with pytest.raises(ValueError):
        store.search(("a.b",))


def test_search_scopes_by_whole_labels_and_pages(make_store: StoreFactory) -> None:
    store = make_store()
    for i in range(7):
        store.put(("docs", "team"), f"d{i}", {"i": i})
    store.put(("docsx",), "other", {"i": 99})
    store.put(("docs",), "top", {"i": 100})
    assert set(keys(store.search(("docs", "team"), limit=100))) == {f"d{i}" for i in range(7)}
    assert set(keys(store.search(("docs",), limit=100))) == {f"d{i}" for i in range(7)} | {"top"}
    assert len(store.search((), limit=100)) == 9
    pages = [keys(store.search(("docs", "team"), limit=3, offset=o)) for o in (0, 3, 6, 9)]
    assert [len(p) for p in pages] == [3, 3, 1, 0]
    assert sorted(k for page in pages for k in page) == sorted(f"d{i}" for i in range(7))
    assert all(item.score is None for item in store.search(("docs",)))


def test_search_filters_match_values_operators_and_nested_objects(make_store: StoreFactory) -> None:
    store = make_store()
    store.put(("m",), "a", {"kind": "casualty", "sev": 3, "where": {"zone": "east"}, "tags": ["x", "y"]})
    store.put(("m",), "b", {"kind": "casualty", "sev": 1, "where": {"zone": "west"}})
    store.put(("m",), "c", {"kind": "crowd", "sev": 5})

    def found(f: dict[str, Any]) -> set[str]:
        return set(keys(store.search(("m",), filter=f, limit=50)))

    assert found({"kind": "casualty"}) == {"a", "b"}
    assert found({"sev": {"$gt": 1}}) == {"a", "c"}
    assert found({"sev": {"$gte": 1, "$lt": 5}}) == {"a", "b"}
    assert found({"sev": {"$lte": 1}}) == {"b"}
    assert found({"kind": {"$ne": "casualty"}}) == {"c"}
    assert found({"kind": {"$eq": "crowd"}}) == {"c"}
    assert found({"where": {"zone": "east"}}) == {"a"}
    assert found({"tags": ["x", "y"]}) == {"a"}
    assert found({"tags": ["y", "x"]}) == set()
    assert found({"missing": "field"}) == set()
    assert found({"kind": "casualty", "sev": 3}) == {"a"}


def test_list_namespaces_prefix_suffix_wildcards_depth_and_pages(make_store: StoreFactory) -> None:
    store = make_store()
    for ns in [("a", "b", "c"), ("a", "b", "d", "e"), ("a", "b", "d", "i"), ("a", "b", "f"), ("a", "c", "f")]:
        store.put(ns, "k", {"v": 1})
    assert store.list_namespaces(prefix=("a", "b"), max_depth=3) == [("a", "b", "c"), ("a", "b", "d"), ("a", "b", "f")]
    assert store.list_namespaces(suffix=("f",)) == [("a", "b", "f"), ("a", "c", "f")]
    assert store.list_namespaces(prefix=("a", "*", "f")) == [("a", "b", "f"), ("a", "c", "f")]
    assert store.list_namespaces(prefix=("a",), suffix=("*", "i")) == [("a", "b", "d", "i")]
    assert store.list_namespaces(max_depth=1) == [("a",)]
    everything = store.list_namespaces()
    assert everything == sorted(everything) and len(everything) == 5
    assert store.list_namespaces(limit=2, offset=1) == everything[1:3]


def test_a_query_ranks_by_meaning_with_cosine_scores(make_store: StoreFactory) -> None:
    store = make_store(index={"dims": len(WORDS), "embed": toy_embed, "fields": ["text"]})
    store.put(("d",), "apple", {"text": "apple apple apple cherry"})
    store.put(("d",), "banana", {"text": "banana"})
    store.put(("d",), "mixed", {"text": "apple banana"})
    store.put(("d",), "unindexed", {"text": "apple apple apple"}, index=False)
    results = store.search(("d",), query="apple", limit=10)
    assert keys(results)[:2] == ["apple", "mixed"]
    assert results[0].score == pytest.approx(3 / math.sqrt(10), abs=1e-5)
    assert results[1].score == pytest.approx(1 / math.sqrt(2), abs=1e-5)
    assert "unindexed" in keys(results) and results[keys(results).index("unindexed")].score is None
    assert keys(store.search(("d",), query="apple", limit=1, offset=1)) == ["mixed"]


def test_index_paths_pick_the_texts_that_are_embedded(make_store: StoreFactory) -> None:
    store = make_store(index={"dims": len(WORDS), "embed": toy_embed, "fields": ["title"]})
    store.put(("d",), "by-title", {"title": "heat", "body": "drone drone drone"})
    store.put(("d",), "by-body", {"title": "drone", "body": "heat heat"})
    store.put(("d",), "notes", {"notes": [{"t": "cherry"}, {"t": "heat"}]}, index=["notes[*].t"])
    ranked = store.search(("d",), query="heat", limit=10)
    assert ranked[0].key in {"by-title", "notes"} and ranked[0].score == pytest.approx(1.0, abs=1e-5)
    by_key = {r.key: r.score for r in ranked}
    assert by_key["notes"] == pytest.approx(1.0, abs=1e-5)  # the best of its two texts
    assert by_key["by-body"] == pytest.approx(0.0, abs=1e-5)


def test_filters_apply_before_the_page_in_a_ranked_search(make_store: StoreFactory) -> None:
    store = make_store(index={"dims": len(WORDS), "embed": toy_embed, "fields": ["text"]})
    for i in range(6):
        store.put(("d",), f"k{i}", {"text": "apple " * (i + 1), "even": i % 2 == 0})
    results = store.search(("d",), query="apple", filter={"even": True}, limit=2)
    assert len(results) == 2 and all(r.value["even"] for r in results)


def test_async_methods_do_what_the_sync_ones_do(make_store: StoreFactory) -> None:
    store = make_store()

    async def go() -> tuple[Any, list[Any], list[Any]]:
        await store.aput(("x", "y"), "k", {"v": 1})
        got = await store.aget(("x", "y"), "k")
        found = await store.asearch(("x",))
        spaces = await store.alist_namespaces(prefix=("x",))
        await store.adelete(("x", "y"), "k")
        return got, found, spaces

    got, found, spaces = asyncio.run(go())
    assert got.value == {"v": 1} and keys(found) == ["k"] and spaces == [("x", "y")]
    assert store.get(("x", "y"), "k") is None
