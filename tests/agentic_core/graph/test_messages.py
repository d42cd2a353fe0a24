"""add_messages, MessagesState and the message contracts, attacked: unknown ids, junk values, foreign messages,
a thousand messages, and the guarantee that the inputs of a merge are left as they were."""

from __future__ import annotations

import pickle
import types
from typing import Annotated

import pytest
from pydantic import ValidationError
from typing_extensions import TypedDict

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.messages import (
    AIMessage,
    HumanMessage,
    MessageError,
    RemoveMessage,
    SystemMessage,
    ToolMessage,
    to_message,
)
from agentic_core.graph import (
    END,
    REMOVE_ALL_MESSAGES,
    START,
    InvalidUpdateError,
    MemorySaver,
    MessagesState,
    StateGraph,
    StateTypeError,
    add_messages,
)


def one_node_graph(update, state=MessagesState):
    builder = StateGraph(state)
    builder.add_node("speak", lambda s: update(s) if callable(update) else update)
    builder.add_edge(START, "speak")
    builder.add_edge("speak", END)
    return builder.compile()


# --- add_messages -------------------------------------------------------------------------------------------------


def test_a_new_id_appends_and_a_known_id_replaces_in_place() -> None:
    base = [HumanMessage("a", id="1"), AIMessage("b", id="2"), HumanMessage("c", id="3")]
    merged = add_messages(base, [AIMessage("B", id="2"), HumanMessage("d", id="4")])
    assert [(m.id, m.content) for m in merged] == [("1", "a"), ("2", "B"), ("3", "c"), ("4", "d")]


def test_the_inputs_are_not_changed() -> None:
    base = [HumanMessage("a")]
    update = [AIMessage("b")]
    merged = add_messages(base, update)
    assert base[0].id is None and update[0].id is None  # copies got the ids
    assert all(m.id for m in merged)
    assert merged is not base


def test_remove_message_of_an_unknown_id_is_a_clear_error() -> None:
    with pytest.raises(MessageError, match=r"RemoveMessage\('ghost'\): no message with that id"):
        add_messages([HumanMessage("a", id="1")], RemoveMessage("ghost"))
    assert issubclass(MessageError, InputError)


def test_remove_then_re_add_in_one_update_keeps_the_message() -> None:
    merged = add_messages([HumanMessage("a", id="1")], [RemoveMessage("1"), HumanMessage("again", id="1")])
    assert [(m.id, m.content) for m in merged] == [("1", "again")]


def test_remove_all_keeps_only_what_follows_it() -> None:
    merged = add_messages(
        [HumanMessage("a", id="1"), AIMessage("b", id="2")], [RemoveMessage(REMOVE_ALL_MESSAGES), ("user", "fresh")]
    )
    assert [(m.type, m.content) for m in merged] == [("human", "fresh")]


@pytest.mark.parametrize(
    ("shorthand", "kind", "content"),
    [
        ("plain text", "human", "plain text"),
        (("user", "hi"), "human", "hi"),
        (("assistant", "hello"), "ai", "hello"),
        (("system", "be brief"), "system", "be brief"),
        ({"role": "user", "content": "dict"}, "human", "dict"),
        ({"type": "ai", "content": "typed"}, "ai", "typed"),
        ({"role": "tool", "content": "4.2", "tool_call_id": "c1"}, "tool", "4.2"),
    ],
)
def test_shorthands_become_messages_with_ids(shorthand, kind, content) -> None:
    (message,) = add_messages([], shorthand)
    assert (message.type, message.content) == (kind, content)
    assert message.id


def test_openai_shaped_tool_calls_are_unpacked() -> None:
    raw = {
        "role": "assistant",
        "content": "",
        "tool_calls": [{"id": "c1", "type": "function", "function": {"name": "wind", "arguments": '{"lat": 1}'}}],
    }
    (message,) = add_messages([], raw)
    assert isinstance(message, AIMessage)
    assert message.tool_calls == [{"name": "wind", "args": {"lat": 1}, "id": "c1"}]


@pytest.mark.parametrize(
    ("junk", "says"),
    [
        (42, r"update\[0\] is a int, not a message"),
        (("wizard", "hi"), r"update\[0\] has role/type 'wizard'"),
        ({"content": "no role"}, r"update\[0\] is a dict without 'role' or 'type'"),
        ({"role": "tool", "content": "x"}, r"update\[0\]: ToolMessage field tool_call_id: Field required"),
        ({"role": "user", "content": "x", "colour": "red"}, r"field colour: Extra inputs are not permitted"),
        (
            {"role": "assistant", "content": "", "tool_calls": [{"id": "c", "function": {"arguments": "{oops"}}]},
            r"tool call 'c': arguments are not JSON",
        ),
    ],
)
def test_junk_is_refused_naming_the_item(junk, says) -> None:
    with pytest.raises(MessageError, match=says):
        add_messages([HumanMessage("a")], junk)


def test_junk_later_in_a_list_is_named_by_its_index() -> None:
    with pytest.raises(MessageError, match=r"update\[2\]"):
        add_messages([], ["fine", ("user", "fine"), object()])


def test_foreign_messages_are_taken_by_their_attributes() -> None:
    # A stand-in for LangChain's classes: only the attributes are looked at, nothing is imported.
    foreign = types.SimpleNamespace(
        type="AIMessageChunk",
        content="calling",
        id=None,
        name=None,
        tool_calls=[{"name": "wind", "args": {}, "id": "c1", "type": "tool_call"}],
    )
    (message,) = add_messages([], foreign)
    assert isinstance(message, AIMessage)
    assert message.tool_calls == [{"name": "wind", "args": {}, "id": "c1"}]
    assert message.id


def test_langchain_messages_are_converted_when_given() -> None:
    lc = pytest.importorskip("langchain_core.messages")
    merged = add_messages(
        [lc.HumanMessage("q", id="h1")],
        [lc.AIMessage("", tool_calls=[{"name": "wind", "args": {"lat": 1}, "id": "c1"}], id="a1"),
         lc.ToolMessage("4.2", tool_call_id="c1", id="t1"), lc.RemoveMessage(id="h1")],
    )  # fmt: skip
    assert [(type(m), m.id) for m in merged] == [(AIMessage, "a1"), (ToolMessage, "t1")]
    assert isinstance(merged[0], AIMessage)
    assert merged[0].tool_calls == [{"name": "wind", "args": {"lat": 1}, "id": "c1"}]


def test_a_thousand_messages() -> None:
    base = [HumanMessage(f"m{i}", id=str(i)) for i in range(1000)]
    update = [AIMessage("replaced", id="500"), RemoveMessage("10"), *[("user", f"n{i}") for i in range(1000)]]
    merged = add_messages(base, update)
    assert len(merged) == 1999
    assert merged[499].content == "replaced"  # position kept, one earlier message gone
    assert "10" not in {m.id for m in merged}
    assert [m.content for m in merged[-3:]] == ["n997", "n998", "n999"]
    assert len({m.id for m in merged}) == 1999


# --- MessagesState in a graph -------------------------------------------------------------------------------------


def test_a_graph_appends_a_thousand_messages_one_step_at_a_time_and_checkpoints_them() -> None:
    def step(state):
        return {"messages": [AIMessage(f"m{len(state['messages'])}")]}

    builder = StateGraph(MessagesState)
    builder.add_node("step", step)
    builder.add_edge(START, "step")
    builder.add_conditional_edges("step", lambda s: "step" if len(s["messages"]) < 1000 else END, ["step", END])
    graph = builder.compile(checkpointer=MemorySaver())
    config = {"configurable": {"thread_id": "long"}, "recursion_limit": 1100}
    out = graph.invoke({"messages": [("user", "go")]}, config)
    assert len(out["messages"]) == 1000
    assert [m.content for m in out["messages"][-2:]] == ["m998", "m999"]
    assert graph.get_state(config).values["messages"] == out["messages"]
    earlier = next(s for s in graph.get_state_history(config) if len(s.values["messages"]) == 500)
    assert earlier.values["messages"] == out["messages"][:500]


def test_a_node_removing_an_unknown_id_fails_naming_the_node() -> None:
    graph = one_node_graph({"messages": RemoveMessage("ghost")})
    with pytest.raises(InvalidUpdateError, match=r"node 'speak' wrote key 'messages'.*RemoveMessage\('ghost'\)"):
        graph.invoke({"messages": [("user", "hi")]})


def test_a_node_writing_junk_fails_naming_node_key_and_item() -> None:
    graph = one_node_graph({"messages": ["fine", 3.5]})
    with pytest.raises(StateTypeError, match=r"node 'speak' wrote key 'messages'.*list\[AnyMessage\].*update\[1\]"):
        graph.invoke({"messages": []})


def test_bad_input_is_refused_before_any_node_runs() -> None:
    ran: list[str] = []

    def speak(state):
        ran.append("speak")
        return {}

    graph = one_node_graph(speak)
    with pytest.raises(StateTypeError, match="update"):
        graph.invoke({"messages": [{"content": "who am I"}]})
    assert ran == []


def test_messages_state_can_be_extended_and_may_be_a_typing_extensions_typeddict() -> None:
    class Mission(MessagesState):
        drone: str

    class Plain(TypedDict):  # typing_extensions' TypedDict: what LangGraph's docs import on Python 3.11
        messages: Annotated[list, add_messages]  # type: ignore[type-arg]
        drone: str

    for state in (Mission, Plain):
        graph = one_node_graph(lambda s: {"messages": ("assistant", f"{s['drone']} ready")}, state)
        out = graph.invoke({"messages": "status?", "drone": "uav-7"})
        assert [m.content for m in out["messages"]] == ["status?", "uav-7 ready"]


# --- the message models -------------------------------------------------------------------------------------------


def test_content_positionally_or_by_keyword_but_not_both() -> None:
    assert HumanMessage("a") == HumanMessage(content="a")
    with pytest.raises(TypeError, match="content given twice"):
        HumanMessage("a", content="b")
    with pytest.raises(ValidationError, match="content"):
        SystemMessage()


def test_required_fields_are_required() -> None:
    with pytest.raises(ValidationError, match="tool_call_id"):
        ToolMessage("x")
    with pytest.raises(ValidationError, match="id"):
        RemoveMessage()
    with pytest.raises(ValidationError, match="tool_calls"):
        AIMessage("", tool_calls=[{"args": {}}])


def test_messages_pickle_and_compare() -> None:
    message = AIMessage("", tool_calls=[{"name": "wind", "args": {"lat": 1.0}, "id": "c1"}], id="a")
    assert pickle.loads(pickle.dumps(message)) == message
    assert to_message(message) is message  # ours pass through untouched


def test_text_joins_content_parts() -> None:
    assert HumanMessage(["look ", {"type": "text", "text": "here"}, {"type": "image_url"}]).text == "look here"
