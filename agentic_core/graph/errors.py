"""Errors raised by the graph runtime. Each names the node, key or edge at fault and says what to do."""

from __future__ import annotations

from typing import Any

from agentic_core.contracts.errors import AgenticUAVError


class GraphError(AgenticUAVError):
    """Base class of every error the graph runtime raises for bad use."""


class GraphCompileError(GraphError, ValueError):
    """The graph's structure is wrong (unknown node, node with no path to END, ...); raised by ``compile()``."""


class InvalidUpdateError(GraphError, ValueError):
    """A node wrote something the state cannot take: two writes to one last-value key, or an unknown key."""


class StateTypeError(InvalidUpdateError, TypeError):
    """A node's update does not match the state schema: names the node, the key, the expected and given type."""

    def __init__(self, node: str, key: str, expected: str, given: str, detail: str = "") -> None:
        self.node, self.key, self.expected, self.given = node, key, expected, given
        msg = f"node {node!r} wrote key {key!r} with a value of type {given}, but the state declares {expected}"
        if detail:
            msg += f" ({detail})"
        super().__init__(msg)


class InvalidRouteError(GraphError, ValueError):
    """A router or ``Command(goto=...)`` named a destination that is not allowed."""


class GraphRecursionError(GraphError, RecursionError):
    """The run reached ``recursion_limit`` supersteps. The last checkpoint is kept, so a run can continue."""


class NodeTimeoutError(GraphError, TimeoutError):
    """A node ran longer than its ``timeout_s``."""


class CheckpointError(GraphError, ValueError):
    """A checkpointer or thread id is missing or wrong, or a stored checkpoint cannot be read."""


class EmptyInputError(GraphError, ValueError):
    """``invoke(None)`` on a thread that has nothing to resume."""


def reject_unsupported(where: str, kwargs: dict[str, Any], harmless: tuple[str, ...] = ()) -> None:
    """Refuse LangGraph keyword arguments this runtime does not implement, instead of ignoring them silently."""
    unsupported = sorted(k for k, v in kwargs.items() if k not in harmless and v is not None and v is not False)
    if unsupported:
        raise GraphError(f"{where}: {', '.join(unsupported)} not supported by agentic_core.graph; remove the argument")


class GraphInterrupt(AgenticUAVError):
    """Raised inside a node by :func:`interrupt` to pause the run; the runtime catches it."""

    def __init__(self, interrupts: tuple[Any, ...]) -> None:
        super().__init__(interrupts)
        self.interrupts = interrupts
