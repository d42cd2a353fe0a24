"""Property tests: the merged state does not depend on the order in which concurrent nodes finish, and the
delta checkpoint encoding rebuilds every state exactly."""

import operator
import threading
from typing import Annotated, Any, TypedDict

from hypothesis import given, settings
from hypothesis import strategies as st

from agentic_core.graph import END, START, InMemorySaver, StateGraph
from agentic_core.graph.checkpoint.base import PickleSerializer, diff_values, values_from_deltas


class S(TypedDict, total=False):
    log: Annotated[list[str], operator.add]
    total: Annotated[int, operator.add]
    last_of_0: str
    last_of_1: str
    last_of_2: str
    last_of_3: str


def build(n: int, finish_order: list[int]) -> Any:
    """n nodes in one superstep; node finish_order[k] may only finish after finish_order[k - 1] has."""
    finished = [threading.Event() for _ in range(n)]
    before = {finish_order[k]: finish_order[k - 1] for k in range(1, n)}

    def make(i: int) -> Any:
        def node(state: S) -> dict[str, Any]:
            if i in before:
                assert finished[before[i]].wait(5)
            finished[i].set()
            return {"log": [f"n{i}"], "total": i + 1, f"last_of_{i}": f"n{i}"}

        return node

    g = StateGraph(S)
    for i in range(n):
        g.add_node(f"n{i}", make(i))
        g.add_edge(START, f"n{i}")
        g.add_edge(f"n{i}", END)
    return g.compile()


@settings(max_examples=25, deadline=None)
@given(st.integers(min_value=2, max_value=4).flatmap(lambda n: st.permutations(list(range(n)))))
def test_merged_state_does_not_depend_on_finish_order(order: list[int]) -> None:
    n = len(order)
    out = build(n, list(order)).invoke({"log": []})
    assert out["log"] == [f"n{i}" for i in range(n)]
    assert out["total"] == n * (n + 1) // 2
    assert all(out[f"last_of_{i}"] == f"n{i}" for i in range(n))


item = st.text(alphabet="abc", max_size=3)
op = st.one_of(
    st.tuples(st.just("append"), st.lists(item, max_size=3)),
    st.tuples(st.just("replace"), st.lists(item, max_size=4)),
    st.tuples(st.just("scalar"), st.integers()),
)


@settings(max_examples=200, deadline=None)
@given(st.lists(op, min_size=1, max_size=25))
def test_deltas_rebuild_every_state(ops: list[tuple[str, Any]]) -> None:
    values: dict[str, Any] = {"items": [], "n": 0}
    saved: dict[str, list[Any]] = {"items": []}
    serde = PickleSerializer()
    chain = [serde.loads(serde.dumps({"items": ("full", []), "n": ("full", 0)}))]  # oldest first
    for kind, arg in ops:
        if kind == "append":
            values["items"].extend(arg)  # in place, the hardest case for prefix detection
            changed = {"items"}
        elif kind == "replace":
            values["items"] = list(arg)
            changed = {"items"}
        else:
            values["n"] = arg
            changed = {"n"}
        chain.append(serde.loads(serde.dumps(diff_values(saved, values, changed))))  # as a saver stores it
        saved["items"] = list(values["items"])
        assert values_from_deltas(reversed(chain)) == values


def test_in_place_reducer_is_checkpointed_correctly() -> None:
    def extend_in_place(left: list[int], right: list[int]) -> list[int]:
        left.extend(right)
        return left

    class T(TypedDict, total=False):
        xs: Annotated[list[int], extend_in_place]
        n: int

    g = StateGraph(T)
    g.add_node("step", lambda s: {"xs": [s["n"]], "n": s["n"] + 1})
    g.add_edge(START, "step")
    g.add_conditional_edges("step", lambda s: "step" if s["n"] < 4 else END, ["step", END])
    app = g.compile(checkpointer=InMemorySaver())
    cfg = {"configurable": {"thread_id": "t"}}
    app.invoke({"n": 0, "xs": []}, cfg)
    assert [h.values["xs"] for h in app.get_state_history(cfg)] == [[0, 1, 2, 3], [0, 1, 2], [0, 1], [0], [], []]
