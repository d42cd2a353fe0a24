"""Checkpointers: one checkpoint per superstep, state history, forks, and storage that grows linearly."""

import operator
from typing import Annotated, Any, TypedDict

import pytest

from agentic_core.graph import (
    END,
    START,
    BaseCheckpointSaver,
    CheckpointError,
    EmptyInputError,
    GraphError,
    InMemorySaver,
    StateGraph,
)


class S(TypedDict, total=False):
    count: int
    log: Annotated[list[str], operator.add]


def cfg(thread: str = "t", **extra: Any) -> dict[str, Any]:
    return {"configurable": {"thread_id": thread, **extra}}


def line(saver: BaseCheckpointSaver) -> Any:
    g = StateGraph(S)
    g.add_node("a", lambda s: {"count": s["count"] + 1, "log": ["a"]})
    g.add_node("b", lambda s: {"count": s["count"] * 10, "log": ["b"]})
    g.add_edge(START, "a")
    g.add_edge("a", "b")
    g.add_edge("b", END)
    return g.compile(checkpointer=saver)


def test_a_checkpoint_after_input_and_every_superstep(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    assert app.invoke({"count": 1, "log": []}, cfg()) == {"count": 20, "log": ["a", "b"]}
    history = list(app.get_state_history(cfg()))
    # as in LangGraph: the input checkpoint holds the state before the input, which the __start__ step applies
    assert [h.metadata["source"] for h in history] == ["loop", "loop", "loop", "input"]
    assert [h.metadata["step"] for h in history] == [2, 1, 0, -1]
    assert [h.next for h in history] == [(), ("b",), ("a",), ("__start__",)]
    assert [h.values.get("count") for h in history] == [20, 2, 1, None]
    assert history[-1].values == {"log": []}
    assert history[0].parent_config == history[1].config
    assert app.get_state(cfg()).values == {"count": 20, "log": ["a", "b"]}


def test_threads_are_independent(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg("one"))
    app.invoke({"count": 5, "log": []}, cfg("two"))
    assert app.get_state(cfg("one")).values["count"] == 20
    assert app.get_state(cfg("two")).values["count"] == 60


def test_new_input_on_an_existing_thread_continues_its_state(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    assert app.invoke({"count": 0}, cfg()) == {"count": 10, "log": ["a", "b", "a", "b"]}


def test_update_state_as_node_forks_the_run(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    after_a = next(h for h in app.get_state_history(cfg()) if h.next == ("b",))
    fork = app.update_state(after_a.config, {"count": 7, "log": ["edited"]}, as_node="a")
    assert app.get_state(fork).next == ("b",)
    assert app.get_state(fork).values == {"count": 7, "log": ["a", "edited"]}
    assert app.invoke(None, fork) == {"count": 70, "log": ["a", "edited", "b"]}
    # the original branch is still there
    assert app.get_state(after_a.config).values == {"count": 2, "log": ["a"]}


def test_update_state_without_as_node_keeps_pending_tasks(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    after_a = next(h for h in app.get_state_history(cfg()) if h.next == ("b",))
    new = app.update_state(after_a.config, {"count": 100})
    assert app.get_state(new).next == ("b",)
    assert app.invoke(None, new)["count"] == 1000


def test_update_state_as_end_finishes(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    after_a = next(h for h in app.get_state_history(cfg()) if h.next == ("b",))
    new = app.update_state(after_a.config, None, as_node=END)
    assert app.get_state(new).next == ()


def test_update_state_is_typed(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    with pytest.raises(GraphError, match="'count'"):
        app.update_state(cfg(), {"count": "many"}, as_node="a")
    with pytest.raises(GraphError, match="no such node"):
        app.update_state(cfg(), {"count": 1}, as_node="nope")


def test_replay_from_an_earlier_checkpoint(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    first = list(app.get_state_history(cfg()))[-1]
    assert first.next == ("__start__",)
    assert app.invoke(None, first.config) == {"count": 20, "log": ["a", "b"]}
    assert len(list(app.get_state_history(cfg()))) == 7  # the replay added three checkpoints on a branch


def test_history_filter_before_and_limit(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    assert [h.metadata["source"] for h in app.get_state_history(cfg(), filter={"source": "input"})] == ["input"]
    newest = app.get_state(cfg())
    assert [h.values.get("count") for h in app.get_state_history(cfg(), before=newest.config)] == [2, 1, None]
    assert len(list(app.get_state_history(cfg(), limit=1))) == 1


def test_missing_thread_id_and_missing_checkpointer_are_explained() -> None:
    app = line(InMemorySaver())
    with pytest.raises(CheckpointError, match="thread_id"):
        app.invoke({"count": 1})
    g = StateGraph(S)
    g.add_node("a", lambda s: None)
    g.add_edge(START, "a")
    g.add_edge("a", END)
    with pytest.raises(CheckpointError, match=r"compile\(checkpointer=InMemorySaver\(\)\)"):
        g.compile().get_state(cfg())


def test_resuming_a_thread_that_does_not_exist(saver: BaseCheckpointSaver) -> None:
    with pytest.raises(EmptyInputError, match="nothing to resume"):
        line(saver).invoke(None, cfg("ghost"))


def test_unknown_checkpoint_id(saver: BaseCheckpointSaver) -> None:
    app = line(saver)
    app.invoke({"count": 1, "log": []}, cfg())
    with pytest.raises(CheckpointError, match="no checkpoint 'nope'"):
        app.get_state(cfg(checkpoint_id="nope"))


def test_get_state_of_an_empty_thread(saver: BaseCheckpointSaver) -> None:
    snap = line(saver).get_state(cfg("empty"))
    assert snap.values == {} and snap.next == ()


def storage_after(saver_factory: Any, steps: int) -> int:
    saver = saver_factory()
    g = StateGraph(S)
    g.add_node("step", lambda s: {"log": [f"item-{len(s['log']):06d}"], "count": s["count"] + 1})
    g.add_edge(START, "step")
    g.add_conditional_edges("step", lambda s: "step" if s["count"] < steps else END, ["step", END])
    app = g.compile(checkpointer=saver)
    out = app.invoke({"count": 0, "log": []}, {**cfg(), "recursion_limit": steps + 5})
    assert len(out["log"]) == steps
    assert app.get_state(cfg()).values["log"] == out["log"]  # rebuilt from deltas, identical
    size: int = saver.storage_bytes()
    return size


@pytest.mark.parametrize("kind", ["memory", "sqlite"])
def test_append_lists_are_stored_as_deltas_so_storage_grows_linearly(kind: str, tmp_path: Any) -> None:
    from agentic_core.graph import SqliteSaver

    counter = iter(range(100))

    def factory() -> BaseCheckpointSaver:
        if kind == "memory":
            return InMemorySaver()
        return SqliteSaver(tmp_path / f"{next(counter)}.sqlite")

    small, large = storage_after(factory, 200), storage_after(factory, 800)
    # quadratic growth would make the ratio about 16; linear growth about 4
    assert large / small < 4.5, (small, large)


def test_history_values_rebuild_every_checkpoint_exactly(saver: BaseCheckpointSaver) -> None:
    g = StateGraph(S)
    g.add_node("step", lambda s: {"log": [str(s["count"])], "count": s["count"] + 1})
    g.add_edge(START, "step")
    g.add_conditional_edges("step", lambda s: "step" if s["count"] < 5 else END, ["step", END])
    app = g.compile(checkpointer=saver)
    app.invoke({"count": 0, "log": []}, cfg())
    logs = [h.values["log"] for h in app.get_state_history(cfg())]
    assert logs == [[str(i) for i in range(n)] for n in range(5, -1, -1)] + [[]]  # + the pre-input checkpoint


def test_a_failed_step_resumes_without_rerunning_its_finished_tasks(saver: BaseCheckpointSaver) -> None:
    calls = {"steady": 0, "flaky": 0}

    def steady(state: S) -> dict[str, list[str]]:
        calls["steady"] += 1
        return {"log": ["steady"]}

    def flaky(state: S) -> dict[str, list[str]]:
        calls["flaky"] += 1
        if calls["flaky"] == 1:
            raise ConnectionError("telemetry link lost")
        return {"log": ["flaky"]}

    g = StateGraph(S)
    g.add_node("steady", steady)
    g.add_node("flaky", flaky)
    g.add_edge(START, "steady")
    g.add_edge(START, "flaky")
    g.add_edge("steady", END)
    g.add_edge("flaky", END)
    app = g.compile(checkpointer=saver)
    with pytest.raises(ConnectionError):
        app.invoke({"log": []}, cfg())
    snap = app.get_state(cfg())
    assert snap.next == ("flaky",)  # steady finished and its write is kept
    assert snap.values == {"log": ["steady"]}
    errors = {t.name: t.error for t in snap.tasks}
    assert errors == {"steady": None, "flaky": "ConnectionError: telemetry link lost"}
    assert app.invoke(None, cfg()) == {"log": ["flaky", "steady"]}
    assert calls == {"steady": 1, "flaky": 2}
