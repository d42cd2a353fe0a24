"""Errors of the tools layer. Only definition mistakes raise; calls always return a ToolResult."""

from __future__ import annotations

from collections.abc import Sequence

from agentic_core.contracts.errors import AgenticUAVError, RunFailure
from agentic_core.contracts.problems import LocatedProblem, ProblemsError


class ToolDefinitionError(ProblemsError):
    """A tool is defined wrongly: a bad name, schema, rate string or signature. Raised at registration.

    A definition file's problems are located (``file:line:col: message``, one per line); a definition made in code
    is one message without a place.

    >>> print(ToolDefinitionError([LocatedProblem("api.yaml", 3, 5, "tools[0].method: unknown method 'FETCH'")]))
    api.yaml:3:5: tools[0].method: unknown method 'FETCH'
    >>> ToolDefinitionError("tool 'x': no name").problems[0].file
    ''
    """

    def __init__(self, problems: str | Sequence[LocatedProblem]) -> None:
        super().__init__([LocatedProblem("", None, None, problems)] if isinstance(problems, str) else problems)


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
