"""Errors of the tools layer. Only definition mistakes raise; calls always return a ToolResult."""

from __future__ import annotations

from agentic_core.contracts.errors import AgenticUAVError, InputError, RunFailure


class ToolDefinitionError(InputError):
    """A tool is defined wrongly: a bad name, schema, rate string or signature. Raised at registration."""


class UnknownToolError(AgenticUAVError, KeyError):
    """No tool of that name; the message lists the closest names."""

    def __init__(self, name: str, closest: list[str]) -> None:
        hint = f"; did you mean {', '.join(repr(c) for c in closest)}?" if closest else ""
        self.message = f"unknown tool {name!r}{hint}"
        self.closest = closest
        super().__init__(name)

    def __str__(self) -> str:
        return self.message


class TransientToolError(RunFailure):
    """Raise from a tool for a failure worth retrying (a busy backend, a dropped link)."""


class ToolError(RunFailure):
    """Raise from a tool for a failure the agent should see as is, never retried."""


class CallTimeout(AgenticUAVError, TimeoutError):
    """The executor stopped waiting for a tool: its attempt ran past its timeout, or the call's deadline came."""


class DeadlinePassed(CallTimeout):
    """The call's deadline came before another attempt could start."""
