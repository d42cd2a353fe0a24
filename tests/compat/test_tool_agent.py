"""A tool-calling agent: a chat model asks for tools, a ToolNode runs them, the model answers from their results.

The program is written once, as a LangGraph user writes it (MessagesState, ToolNode, tools_condition,
MemorySaver); the two runs differ only in where those names and the message classes come from. The chat model
is a stand-in that asks for two tools at once on a question about the weather, and otherwise answers.
"""

from __future__ import annotations

import json
from typing import Any

from .conftest import AgentAPI


def get_weather(city: str) -> dict[str, float]:
    """Wind and temperature at a city.

    Args:
        city: the city's name
    """
    return {"wind_mps": round(len(city) * 0.7, 1), "temp_c": 20.0 + len(city)}


def battery_level(drone: str) -> int:
    """A drone's battery charge in percent.

    Args:
        drone: the drone's id
    """
    return 100 - sum(map(ord, drone)) % 40


class StandInModel:
    """A chat model that calls both tools for a weather question and then answers from their results."""

    def __init__(self, api: AgentAPI) -> None:
        self.api = api
        self.seen: list[int] = []

    def invoke(self, messages: list[Any]) -> Any:
        self.seen.append(len(messages))
        last = messages[-1]
        if last.type == "human" and "weather" in last.content:
            return self.api.AIMessage(
                content="Checking the weather and the battery.",
                tool_calls=[
                    {"name": "get_weather", "args": {"city": "Mecca"}, "id": "call_weather"},
                    {"name": "battery_level", "args": {"drone": "uav-7"}, "id": "call_battery"},
                ],
            )
        if last.type == "tool":
            results = {m.tool_call_id: m.content for m in messages if m.type == "tool"}
            return self.api.AIMessage(
                content=f"Weather {results['call_weather']}; battery {results['call_battery']}%.",
            )
        return self.api.AIMessage(content=f"You said: {last.content}")


def build_agent(api: AgentAPI, model: StandInModel):
    StateGraph, START, MessagesState = api.StateGraph, api.START, api.MessagesState
    ToolNode, tools_condition, MemorySaver = api.ToolNode, api.tools_condition, api.MemorySaver

    def call_model(state: MessagesState):  # type: ignore[valid-type]
        return {"messages": [model.invoke(state["messages"])]}  # type: ignore[index]

    builder = StateGraph(MessagesState)
    builder.add_node("agent", call_model)
    builder.add_node("tools", ToolNode([get_weather, battery_level]))
    builder.add_edge(START, "agent")
    builder.add_conditional_edges("agent", tools_condition)
    builder.add_edge("tools", "agent")
    return builder.compile(checkpointer=MemorySaver())


def summary(message: Any) -> tuple[Any, ...]:
    """What a message says, without its generated id."""
    calls = [(c["name"], c["args"], c["id"]) for c in getattr(message, "tool_calls", None) or []]
    return (
        message.type,
        message.content,
        calls,
        getattr(message, "tool_call_id", None),
        getattr(message, "status", None),
        message.name,
    )


def run_two_turns(api: AgentAPI) -> tuple[Any, Any, Any]:
    model = StandInModel(api)
    graph = build_agent(api, model)
    config = {"configurable": {"thread_id": "agent-1"}}
    first = graph.invoke({"messages": [("user", "What is the weather in Mecca?")]}, config)
    second = graph.invoke({"messages": [api.HumanMessage(content="thanks")]}, config)
    return graph, config, (first, second, model.seen)


EXPECTED_WEATHER = get_weather("Mecca")
EXPECTED_BATTERY = battery_level("uav-7")


def test_the_agent_calls_both_tools_and_answers_from_their_results(agent_api: AgentAPI) -> None:
    _, _, (first, _, seen) = run_two_turns(agent_api)
    weather_json = json.dumps(EXPECTED_WEATHER)
    assert [summary(m) for m in first["messages"]] == [
        ("human", "What is the weather in Mecca?", [], None, None, None),
        (
            "ai",
            "Checking the weather and the battery.",
            [
                ("get_weather", {"city": "Mecca"}, "call_weather"),
                ("battery_level", {"drone": "uav-7"}, "call_battery"),
            ],
            None,
            None,
            None,
        ),
        ("tool", weather_json, [], "call_weather", "success", "get_weather"),
        ("tool", str(EXPECTED_BATTERY), [], "call_battery", "success", "battery_level"),
        ("ai", f"Weather {weather_json}; battery {EXPECTED_BATTERY}%.", [], None, None, None),
    ]
    assert seen[:2] == [1, 4]  # the model saw the question, then the question, its call and both answers
    ids = [m.id for m in first["messages"]]
    assert all(isinstance(i, str) and i for i in ids)
    assert len(set(ids)) == len(ids)


def test_the_same_final_messages_on_both_runtimes(agent_api: AgentAPI) -> None:
    from .conftest import agentic_agent_api, langgraph_agent_api

    other = langgraph_agent_api() if agent_api.name == "agentic_core" else agentic_agent_api()
    _, _, (_, mine, _) = run_two_turns(agent_api)
    _, _, (_, theirs, _) = run_two_turns(other)
    assert [summary(m) for m in mine["messages"]] == [summary(m) for m in theirs["messages"]]
    assert [summary(m) for m in mine["messages"]][-2:] == [
        ("human", "thanks", [], None, None, None),
        ("ai", "You said: thanks", [], None, None, None),
    ]


def history(api: AgentAPI) -> list[tuple[Any, ...]]:
    graph, config, _ = run_two_turns(api)
    return [
        (
            snapshot.next,
            snapshot.metadata["source"],
            snapshot.metadata["step"],
            [summary(m) for m in snapshot.values.get("messages", [])],
        )
        for snapshot in graph.get_state_history(config)
    ]


def test_the_same_checkpointed_history_on_both_runtimes(agent_api: AgentAPI) -> None:
    from .conftest import agentic_agent_api, langgraph_agent_api

    mine = history(agent_api)
    theirs = history(langgraph_agent_api() if agent_api.name == "agentic_core" else agentic_agent_api())
    assert mine == theirs
    # Newest first: turn two (input, START step, agent) above turn one (input, START, agent, tools, agent).
    assert [(nxt, step) for nxt, _, step, _ in mine] == [
        ((), 6),
        (("agent",), 5),
        (("__start__",), 4),
        ((), 3),
        (("agent",), 2),
        (("tools",), 1),
        (("agent",), 0),
        (("__start__",), -1),
    ]
    assert [len(messages) for *_, messages in mine] == [7, 6, 5, 5, 4, 2, 1, 0]


def test_updates_stream_shows_the_tool_messages(agent_api: AgentAPI) -> None:
    graph = build_agent(agent_api, StandInModel(agent_api))
    config = {"configurable": {"thread_id": "stream"}}
    chunks = list(graph.stream({"messages": [("user", "weather?")]}, config, stream_mode="updates"))
    assert [next(iter(c)) for c in chunks] == ["agent", "tools", "agent"]
    tool_messages = chunks[1]["tools"]["messages"]
    assert [(m.tool_call_id, m.status) for m in tool_messages] == [
        ("call_weather", "success"),
        ("call_battery", "success"),
    ]


def test_add_messages_replaces_by_id_removes_and_coerces(agent_api: AgentAPI) -> None:
    api = agent_api
    StateGraph, START, END = api.StateGraph, api.START, api.END

    def draft(state):
        return {"messages": [api.AIMessage(content="draft", id="a1"), {"role": "user", "content": "more"}]}

    def revise(state):
        first = state["messages"][0]
        return {"messages": [api.AIMessage(content="final", id="a1"), api.RemoveMessage(id=first.id)]}

    builder = StateGraph(api.MessagesState)
    builder.add_node("draft", draft)
    builder.add_node("revise", revise)
    builder.add_edge(START, "draft")
    builder.add_edge("draft", "revise")
    builder.add_edge("revise", END)
    out = builder.compile().invoke({"messages": [("system", "be brief"), "hello"]})
    assert [(m.type, m.content) for m in out["messages"]] == [("human", "hello"), ("ai", "final"), ("human", "more")]
    assert out["messages"][1].id == "a1"


def test_add_messages_called_directly(agent_api: AgentAPI) -> None:
    api = agent_api
    left = [api.HumanMessage(content="q", id="1"), api.AIMessage(content="a", id="2")]
    merged = api.add_messages(left, api.AIMessage(content="a2", id="2"))
    assert [(m.id, m.content) for m in merged] == [("1", "q"), ("2", "a2")]
    assert [m.content for m in left] == ["q", "a"]  # the inputs are not changed
    assert [m.id for m in api.add_messages(merged, [api.RemoveMessage(id="1")])] == ["2"]
    appended = api.add_messages(merged, [("assistant", "more")])
    assert [m.type for m in appended] == ["human", "ai", "ai"]
    assert appended[-1].id
