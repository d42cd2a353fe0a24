"""The one error root. Every exception the project defines derives from :class:`AgenticUAVError`, so a caller can
catch all of ours in one place; the CLI maps :class:`InputError` to exit status 2 and :class:`RunFailure` to 1.

>>> issubclass(InputError, AgenticUAVError), InputError.exit_status, RunFailure.exit_status
(True, 2, 1)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from pydantic import ValidationError


class AgenticUAVError(Exception):
    """Root of every error agentic-uavs raises on purpose."""

    exit_status = 1


class InputError(AgenticUAVError, ValueError):
    """Bad input from a user (a file, a field, an option): the message names where. Exit status 2."""

    exit_status = 2


class RunFailure(AgenticUAVError, RuntimeError):
    """A run (or command) that started and could not do what it was asked. Exit status 1."""

    exit_status = 1


def report_error(prog: str, error: AgenticUAVError, stream: TextIO) -> int:
    """Print ``error`` as ``prog: error: message`` (no traceback) and return its exit status, for a CLI's ``main``.

    >>> import io
    >>> report_error("agentic-uav", InputError("a.yaml:3:5: no such field"), io.StringIO())
    2
    """
    message = " ".join(str(error).split("\n")[:1]) or type(error).__name__
    rest = str(error).split("\n")[1:]
    print(f"{prog}: error: {message}", *rest, sep="\n", file=stream)
    return error.exit_status


def option_problem(exc: ValidationError) -> str:
    """The first problem pydantic found in settings made from command-line options, named as the option:
    ``--camera-hz: Input should be greater than 0``."""
    first = exc.errors()[0]
    name = str(first["loc"][0]).replace("_", "-") if first["loc"] else "options"
    return f"--{name}: {str(first['msg']).removeprefix('Value error, ')}"


def field_problem(exc: ValidationError, within: str = "") -> str:
    """The first problem pydantic found, named by its field's dotted path (under ``within`` when given):
    ``calibration.by_size.0.probs: Input should be a valid list``.

    >>> from pydantic import BaseModel, ValidationError
    >>> class Band(BaseModel):
    ...     probs: list[float]
    >>> try:
    ...     Band.model_validate({"probs": "high"})
    ... except ValidationError as exc:
    ...     print(field_problem(exc, "calibration"))
    calibration.probs: Input should be a valid list
    """
    first = exc.errors()[0]
    where = ".".join(str(part) for part in (within, *first["loc"]) if part != "")
    return f"{where}: {first['msg']}" if where else str(first["msg"])


__all__ = ["AgenticUAVError", "InputError", "RunFailure", "field_problem", "option_problem", "report_error"]
