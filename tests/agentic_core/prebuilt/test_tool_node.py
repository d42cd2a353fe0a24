"""ToolNode and tools_condition, attacked: unknown tools, bad arguments, tools that raise, denied scopes, rate
limits, malformed calls. Every failure must come back as an error ToolMessage naming the reason, never raise."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator
from typing import Any

import pytest
from pydantic import BaseModel

from agentic_core.contracts.messages import AIMessage, AnyMessage, HumanMessage, ToolMessage
from agentic_core.graph import START, GraphError, MessagesState, StateGraph
from agentic_core.prebuilt import ToolNode, tools_condition
from tools import Caller, MemoryAuditLog, ToolDefinitionError, ToolExecutor, ToolRegistry, ToolSpec, tool


def add(a: int, b: int) -> int:
    """Add two numbers."""
    return a + b


def explode(reason: str) -> str:
    """Fail on purpose."""
    raise RuntimeError(f"boom: {reason}")


@tool(name="flight.arm", scopes=["flight:command"])
def arm(drone: str) -> str:
    """Arm a drone's motors."""
    return f"{drone} armed"


def asks(*calls: tuple[str, Any]) -> dict[str, list[AIMessage]]:
    """A state whose last message asks for ``calls`` (name, args), with ids c0, c1, ..."""
    tool_calls = [{"name": name, "args": args, "id": f"c{i}"} for i, (name, args) in enumerate(calls)]
    return {"messages": [AIMessage("", tool_calls=tool_calls)]}


def answers(node: ToolNode, state: Any) -> list[ToolMessage]:
    out = node(state)
    assert isinstance(out, dict)
    return out["messages"]


@pytest.fixture
def node() -> Iterator[ToolNode]:
    tool_node = ToolNode([add, explode, arm])
    yield tool_node
    tool_node.close()


def test_a_good_call_is_answered(node: ToolNode) -> None:
    (message,) = answers(node, asks(("add", {"a": 2, "b": 40})))
    assert (message.content, message.status, message.tool_call_id, message.name) == (
        str(add(2, 40)),
        "success",
        "c0",
        "add",
    )
    assert message.artifact is not None and message.artifact["tool"] == "tools.add"


def test_an_unknown_tool_is_an_error_message_and_the_other_calls_still_run(node: ToolNode) -> None:
    unknown, good = answers(node, asks(("ad", {"a": 1, "b": 1}), ("add", {"a": 1, "b": 1})))
    assert unknown.status == "error"
    assert "unknown tool 'ad'" in str(unknown.content)
    assert "the tools are: tools.add, tools.explode, flight.arm" in str(unknown.content)
    assert (good.status, good.content) == ("success", "2")


@pytest.mark.parametrize(
    ("args", "says"),
    [
        ({"a": "two", "b": 3}, "$.a: 'two' is not of type 'integer'"),
        ({"a": 1}, "'b' is a required property"),
        ({"a": 1, "b": 2, "c": 3}, "Additional properties are not allowed"),
        ("a=1,b=2", "expected an object"),
        (None, "'a' is a required property"),
    ],
)
def test_bad_arguments_are_an_error_message_naming_the_field(node: ToolNode, args: Any, says: str) -> None:
    calls = [{"name": "add", "args": args, "id": "c0"}]
    foreign = type("Foreign", (), {"type": "ai", "tool_calls": calls})()  # ours would refuse such args up front
    (message,) = answers(node, {"messages": [foreign]})
    assert message.status == "error"
    assert says in str(message.content)


def test_a_tool_that_raises_is_an_error_message(node: ToolNode) -> None:
    (message,) = answers(node, asks(("explode", {"reason": "on purpose"})))
    assert message.status == "error"
    assert "RuntimeError: boom: on purpose" in str(message.content)


def test_a_denied_scope_is_an_error_message_and_is_audited() -> None:
    audit = MemoryAuditLog()
    node = ToolNode([arm], caller=Caller(id="guest"), audit=audit)
    (message,) = answers(node, asks(("flight.arm", {"drone": "uav-7"})))
    assert message.status == "error"
    assert "denied" in str(message.content) and "'guest' lacks scope flight:command" in str(message.content)
    assert [(r.caller, r.tool, r.status) for r in audit.records] == [("guest", "flight.arm", "denied")]
    pilot = ToolNode([arm], caller=Caller(id="pilot", scopes=frozenset({"flight:*"})))
    (allowed,) = answers(pilot, asks(("arm", {"drone": "uav-7"})))  # by its last name part too
    assert (allowed.status, allowed.content) == ("success", arm("uav-7"))


def test_a_rate_limited_call_is_an_error_message_saying_when_to_retry() -> None:
    spec = ToolSpec.from_schema(
        "camera.snap",
        lambda args: "click",
        input_schema={"type": "object"},
        rate_limit="1/h",
    )
    node = ToolNode([spec])
    first, second = answers(node, asks(("camera.snap", {}), ("camera.snap", {})))
    statuses = sorted([first.status, second.status])
    assert statuses == ["error", "success"]
    refused = first if first.status == "error" else second
    assert "rate_limited" in str(refused.content) and "retry in" in str(refused.content)


def test_malformed_foreign_tool_calls_are_error_messages(node: ToolNode) -> None:
    calls = [{"args": {}, "id": "x"}, "not a call", {"name": "add", "args": {"a": 1, "b": 2}, "id": "ok"}]
    foreign = type("Foreign", (), {"type": "ai", "tool_calls": calls})()
    nameless, junk, good = answers(node, {"messages": [foreign]})
    assert (nameless.status, nameless.tool_call_id) == ("error", "x")
    assert junk.status == "error" and "not a call" in str(junk.content)
    assert (good.status, good.content) == ("success", "3")


def test_several_calls_run_at_once_and_answer_in_the_order_asked() -> None:
    both_in = threading.Barrier(2, timeout=10)
    second_done = threading.Event()

    def first(x: int) -> int:
        """Waits until the second call has finished."""
        both_in.wait()
        assert second_done.wait(10)
        return x

    def second(x: int) -> int:
        """Finishes first."""
        both_in.wait()
        second_done.set()
        return x

    node = ToolNode([first, second])
    out = answers(node, asks(("first", {"x": 1}), ("second", {"x": 2})))
    assert [(m.tool_call_id, m.content, m.status) for m in out] == [("c0", "1", "success"), ("c1", "2", "success")]


def test_max_parallel_one_runs_calls_one_after_another() -> None:
    inside = 0
    most = 0
    lock = threading.Lock()

    def count(x: int) -> int:
        """Records how many calls are inside at once."""
        nonlocal inside, most
        with lock:
            inside += 1
            most = max(most, inside)
        with lock:
            inside -= 1
        return x

    node = ToolNode([count], max_parallel=1)
    out = answers(node, asks(*[("count", {"x": i}) for i in range(5)]))
    assert [m.content for m in out] == ["0", "1", "2", "3", "4"]
    assert most == 1
    with pytest.raises(GraphError, match="max_parallel"):
        ToolNode([count], max_parallel=0)


def test_an_existing_executor_is_used_with_its_registry_and_caller() -> None:
    registry = ToolRegistry()
    registry.register(arm)
    executor = ToolExecutor(registry, default_caller=Caller(id="ops", scopes=frozenset({"flight:command"})))
    node = ToolNode(executor)
    by_openai_name, by_full_name = answers(node, asks(("flight__arm", {"drone": "a"}), ("flight.arm", {"drone": "b"})))
    assert [by_openai_name.content, by_full_name.content] == ["a armed", "b armed"]
    assert [r.caller for r in executor.audit.records] == ["ops", "ops"]  # type: ignore[attr-defined]
    with pytest.raises(GraphError, match="audit"):
        ToolNode(executor, audit=MemoryAuditLog())


def test_an_ambiguous_short_name_is_not_guessed() -> None:
    one = ToolSpec.from_schema("a.ping", lambda args: "a", input_schema={"type": "object"})
    two = ToolSpec.from_schema("b.ping", lambda args: "b", input_schema={"type": "object"})
    (message,) = answers(ToolNode([one, two]), asks(("ping", {})))
    assert message.status == "error" and "unknown tool 'ping'" in str(message.content)


class Fix(BaseModel):
    lat: float
    lon: float


def test_async_tools_and_structured_outputs() -> None:
    async def locate(drone: str) -> Fix:
        """Where a drone is."""
        await asyncio.sleep(0)
        return Fix(lat=21.4, lon=39.8)

    (message,) = answers(ToolNode([locate]), asks(("locate", {"drone": "uav-7"})))
    assert message.status == "success"
    assert Fix.model_validate_json(str(message.content)) == Fix(lat=21.4, lon=39.8)


def test_bad_tools_are_refused_when_the_node_is_made() -> None:
    with pytest.raises(GraphError, match=r"tools\[1\] is a int"):
        ToolNode([add, 3])  # type: ignore[list-item]
    with pytest.raises(GraphError, match="must be a list"):
        ToolNode("add")  # type: ignore[arg-type]

    def untyped(x):
        """No hints."""
        return x

    with pytest.raises(ToolDefinitionError, match="parameter 'x' needs a type hint"):
        ToolNode([untyped])


def test_inputs_it_reads(node: ToolNode) -> None:
    state_list = asks(("add", {"a": 1, "b": 1}))["messages"]
    out = node(state_list)
    assert isinstance(out, list) and out[0].content == "2"  # a list in, a list out

    class Chat(BaseModel):
        messages: list[AnyMessage]

    model_out = node(Chat(messages=list(state_list)))
    assert isinstance(model_out, dict) and model_out["messages"][0].content == "2"
    with pytest.raises(GraphError, match="no 'messages'"):
        node({"messages": []})
    with pytest.raises(GraphError, match="no AI message"):
        node({"messages": [HumanMessage("hi")]})
    assert node({"messages": [AIMessage("no calls")]}) == {"messages": []}


def test_tools_condition_routes() -> None:
    assert tools_condition(asks(("add", {}))) == "tools"
    assert tools_condition({"messages": [AIMessage("done")]}) == "__end__"
    assert tools_condition([HumanMessage("hi")]) == "__end__"
    assert (
        tools_condition({"chat": [AIMessage("", tool_calls=[{"name": "x", "args": {}, "id": "1"}])]}, "chat") == "tools"
    )
    with pytest.raises(GraphError, match="no 'messages'"):
        tools_condition({"messages": []})


def test_in_a_graph_run_asynchronously_errors_go_back_to_the_model() -> None:
    def model(state: MessagesState) -> dict[str, list[AIMessage]]:
        last = state["messages"][-1]
        if last.type == "tool":
            return {"messages": [AIMessage(f"the tool said: {last.content}")]}
        return {"messages": [AIMessage("", tool_calls=[{"name": "explode", "args": {"reason": "x"}, "id": "1"}])]}

    builder = StateGraph(MessagesState)
    builder.add_node("agent", model)
    builder.add_node(ToolNode([explode]))
    builder.add_edge(START, "agent")
    builder.add_conditional_edges("agent", tools_condition)
    builder.add_edge("tools", "agent")
    out = asyncio.run(builder.compile().ainvoke({"messages": [("user", "go")]}))
    assert [m.type for m in out["messages"]] == ["human", "ai", "tool", "ai"]
    assert out["messages"][2].status == "error"
    assert "boom: x" in out["messages"][-1].content
