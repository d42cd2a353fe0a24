"""``ToolNode`` and ``tools_condition``: the tool step of a tool-calling agent, run through the guarded executor.

A ToolNode reads the last AI message's ``tool_calls``, runs each through a :class:`tools.ToolExecutor` (argument
validation, scopes, rate limits, timeouts, the audit log), several at once when there are several, and answers
each call with a ToolMessage in the order asked. A failed or refused call is a ToolMessage with status "error"
and the reason, for the model to read: a ToolNode does not raise for a tool's failure.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Literal

from tools import AuditLog, Caller, ToolExecutor, ToolRegistry, ToolResult, ToolSpec
from tools.function import is_tool, spec_from_function, tool_spec

from ..contracts.messages import ToolMessage
from ..graph.errors import GraphError

ToolLike = Callable[..., Any] | ToolSpec


def _as_spec(item: Any, index: int, namespace: str) -> ToolSpec:
    if isinstance(item, ToolSpec):
        return item
    if is_tool(item):
        return tool_spec(item)
    if callable(item) and hasattr(item, "__name__"):
        return spec_from_function(item, name=f"{namespace}.{item.__name__}")
    raise GraphError(
        f"ToolNode: tools[{index}] is a {type(item).__name__}; give typed functions, ToolSpecs or a ToolExecutor"
    )


def _messages(state: Any, key: str) -> list[Any]:
    if isinstance(state, list):
        return state
    messages = state.get(key) if isinstance(state, Mapping) else getattr(state, key, None)
    if not messages:
        raise GraphError(f"ToolNode: the state has no {key!r} to read tool calls from")
    return list(messages)


def _content(output: Any) -> str:
    """A tool's output as message text: a string as it is, anything else as JSON (as LangChain writes it)."""
    if isinstance(output, str):
        return output
    try:
        return json.dumps(output, ensure_ascii=False)
    except (TypeError, ValueError):
        return str(output)


def _refusal(result: ToolResult) -> str:
    reason = result.error or result.status
    if result.retry_after_s is not None:
        reason += f" (retry in {result.retry_after_s:.3g} s)"
    return f"Error ({result.status}): {reason}"


class ToolNode:
    """A graph node that runs the tool calls of the last AI message. ``tools`` are typed functions (named
    ``<namespace>.<function name>``; the model may call them by the function name alone), :class:`ToolSpec`\\ s, or
    one :class:`ToolExecutor` whose registry and guards are used as they are. ``caller`` is who the calls run as
    (its scopes are checked); ``max_parallel`` bounds the calls run at once.

    >>> from agentic_core.contracts.messages import AIMessage
    >>> def add(a: int, b: int) -> int:
    ...     '''Add two numbers.'''
    ...     return a + b
    >>> node = ToolNode([add])
    >>> call = AIMessage("", tool_calls=[{"name": "add", "args": {"a": 2, "b": 3}, "id": "c1"}])
    >>> [(m.content, m.status) for m in node({"messages": [call]})["messages"]]
    [('5', 'success')]
    >>> bad = AIMessage("", tool_calls=[{"name": "add", "args": {"a": "two", "b": 3}, "id": "c2"}])
    >>> node({"messages": [bad]})["messages"][0].content
    "Error (error): invalid arguments: $.a: 'two' is not of type 'integer'"
    """

    def __init__(
        self,
        tools: Sequence[ToolLike] | ToolExecutor,
        *,
        name: str = "tools",
        messages_key: str = "messages",
        caller: Caller | None = None,
        namespace: str = "tools",
        audit: AuditLog | None = None,
        max_parallel: int = 8,
        timeout_s: float | None = None,
    ) -> None:
        if max_parallel < 1:
            raise GraphError(f"ToolNode: max_parallel must be at least 1, got {max_parallel}")
        if isinstance(tools, ToolExecutor):
            if audit is not None:
                raise GraphError("ToolNode: an executor given keeps its own audit log; do not pass audit too")
            self.executor = tools
        else:
            given: object = tools  # callers pass anything; the annotation is what we accept
            if isinstance(given, str | bytes) or not isinstance(given, Sequence):
                raise GraphError(f"ToolNode: tools must be a list or a ToolExecutor, got {type(tools).__name__}")
            registry = ToolRegistry()
            for index, item in enumerate(tools):
                registry.register(_as_spec(item, index, namespace))
            self.executor = ToolExecutor(registry, audit=audit)
        self.__name__ = name  # add_node(ToolNode(...)) names the node after it, as LangGraph does
        self.name = name
        self.messages_key = messages_key
        self.caller = caller
        self.max_parallel = max_parallel
        self.timeout_s = timeout_s

    def __repr__(self) -> str:
        return f"ToolNode(name={self.name!r}, tools={self.executor.registry.names()})"

    def resolve(self, requested: str) -> str:
        """The registered name a model's tool name stands for: itself, its OpenAI spelling or its last part."""
        registry = self.executor.registry
        resolved = registry.resolve(requested)
        if resolved in registry:
            return resolved
        matches = [n for n in registry.names() if n.rsplit(".", 1)[-1] == requested]
        return matches[0] if len(matches) == 1 else requested

    def run_call(self, call: Any) -> ToolMessage:
        """One tool call (``{"name", "args", "id"}``) through the executor, as a ToolMessage; never raises."""
        if not isinstance(call, Mapping) or not isinstance(call.get("name"), str):
            return ToolMessage(
                f"Error (error): a tool call needs a 'name' and 'args', got {call!r}",
                tool_call_id=str(call.get("id") or "") if isinstance(call, Mapping) else "",
                status="error",
            )
        requested, call_id = call["name"], str(call.get("id") or "")
        name = self.resolve(requested)
        result = self.executor.call(name, call.get("args", {}), caller=self.caller, timeout_s=self.timeout_s)
        artifact = {"tool": result.tool, "status": result.status, "call_id": result.call_id}
        if result.ok:
            return ToolMessage(_content(result.output), tool_call_id=call_id, name=requested, artifact=artifact)
        reason = _refusal(result)
        if name not in self.executor.registry:  # the model asked for a tool that is not there: tell it what is
            reason += f"; the tools are: {', '.join(spec.name for spec in self.executor.registry)}"
        return ToolMessage(reason, tool_call_id=call_id, name=requested, status="error", artifact=artifact)

    def __call__(self, state: Any) -> dict[str, list[ToolMessage]] | list[ToolMessage]:
        """Answer the tool calls of the last AI message in ``state`` (a dict, a model, or a list of messages)."""
        messages = _messages(state, self.messages_key)
        last_ai = next((m for m in reversed(messages) if getattr(m, "type", None) == "ai"), None)
        if last_ai is None:
            raise GraphError(f"ToolNode: no AI message in {self.messages_key!r} to take tool calls from")
        calls = list(getattr(last_ai, "tool_calls", None) or [])
        if len(calls) <= 1:
            answers = [self.run_call(c) for c in calls]
        else:
            with ThreadPoolExecutor(min(len(calls), self.max_parallel), thread_name_prefix="tool-node") as pool:
                answers = list(pool.map(self.run_call, calls))
        return answers if isinstance(state, list) else {self.messages_key: answers}

    def close(self) -> None:
        """Stop the executor's worker threads (an executor passed in is closed too)."""
        self.executor.close()


def tools_condition(state: Any, messages_key: str = "messages") -> Literal["tools", "__end__"]:
    """Route after the model: to ``"tools"`` when its last message asks for tool calls, else to END.

    >>> from agentic_core.contracts.messages import AIMessage
    >>> tools_condition({"messages": [AIMessage("done")]})
    '__end__'
    """
    messages = _messages(state, messages_key)
    return "tools" if getattr(messages[-1], "tool_calls", None) else "__end__"


__all__ = ["ToolNode", "tools_condition"]
