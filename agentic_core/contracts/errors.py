"""The one error root. Every exception the project defines derives from :class:`AgenticUAVError`, so a caller can
catch all of ours in one place; the CLI maps :class:`InputError` to exit status 2 and :class:`RunFailure` to 1.

>>> issubclass(InputError, AgenticUAVError), InputError.exit_status, RunFailure.exit_status
(True, 2, 1)
"""

from __future__ import annotations


class AgenticUAVError(Exception):
    """Root of every error agentic-uavs raises on purpose."""

    exit_status = 1


class InputError(AgenticUAVError, ValueError):
    """Bad input from a user (a file, a field, an option): the message names where. Exit status 2."""

    exit_status = 2


class RunFailure(AgenticUAVError, RuntimeError):
    """A run (or command) that started and could not do what it was asked. Exit status 1."""

    exit_status = 1


__all__ = ["AgenticUAVError", "InputError", "RunFailure"]
