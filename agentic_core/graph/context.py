"""What a running node can reach: ``interrupt()``, the custom stream writer and its config.

The runtime sets a :class:`TaskContext` in a context variable around every node call, so these functions work
from anywhere inside a node (helpers included) without being passed around.
"""

from __future__ import annotations

from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass, field
from typing import Any

from .errors import CheckpointError, GraphError, GraphInterrupt
from .types import Interrupt

_MISSING: Any = object()


@dataclass
class TaskContext:
    """Per-task facts a node can reach through the module functions below."""

    node: str
    task_id: str
    ns: str
    config: dict[str, Any]
    has_checkpointer: bool
    writer: Callable[[Any], None]
    resume: list[Any] = field(default_factory=list)
    fresh_resume: Any = _MISSING
    calls: int = 0
    run: Any = None  # the Run this task belongs to; subgraph nodes read the parent's checkpointer from it
    store: Any = None  # the store given to compile(store=...), or the parent graph's


_current: ContextVar[TaskContext | None] = ContextVar("agentic_graph_task", default=None)


def current_task() -> TaskContext:
    ctx = _current.get()
    if ctx is None:
        raise GraphError("this function can only be called from inside a node while a graph runs")
    return ctx


def interrupt_id(ns: str, task_id: str, index: int) -> str:
    import hashlib

    return hashlib.sha1(f"{ns}|{task_id}|{index}".encode(), usedforsecurity=False).hexdigest()[:16]


def interrupt(value: Any) -> Any:
    """Pause the run and hand ``value`` to the caller; returns the value given by ``Command(resume=...)``.

    The node that called it runs again from its start when the run resumes, and this call then returns the
    resume value instead of pausing, so code before it runs twice: keep side effects after the interrupt, or
    in another node. Nodes that finished in the same superstep are not run again.

    >>> def approve(state):  # doctest: +SKIP
    ...     answer = interrupt({"question": "land near the crowd?"})
    ...     return {"approved": answer == "yes"}
    """
    ctx = current_task()
    if not ctx.has_checkpointer:
        raise CheckpointError(
            f"node {ctx.node!r} called interrupt(), which needs a checkpointer to pause and resume: "
            "compile(checkpointer=InMemorySaver()) and pass config={'configurable': {'thread_id': ...}}"
        )
    index = ctx.calls
    ctx.calls += 1
    if index < len(ctx.resume):
        return ctx.resume[index]
    raise GraphInterrupt((Interrupt(value=value, id=interrupt_id(ctx.ns, ctx.task_id, index)),))


def get_stream_writer() -> Callable[[Any], None]:
    """The writer of ``stream_mode="custom"``: anything passed to it is streamed to the caller as it happens."""
    return current_task().writer


def get_store() -> Any:
    """The store the graph was compiled with (``compile(store=...)``; a subgraph uses its parent's), or None."""
    return current_task().store


def get_config() -> dict[str, Any]:
    """The config of the current run, as passed to ``invoke``/``stream``."""
    return current_task().config
