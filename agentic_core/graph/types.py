"""Public value types of the graph runtime: Send, Command, Interrupt, RetryPolicy, StateSnapshot."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, Generic, Literal, TypeVar, cast

N = TypeVar("N")

StreamMode = Literal["values", "updates", "debug", "custom"]
STREAM_MODES: tuple[str, ...] = ("values", "updates", "debug", "custom")


@dataclass(frozen=True)
class Send:
    """Run ``node`` once in the next superstep with ``arg`` as its input (fan-out, map-reduce).

    >>> Send("grade", {"item": 3})
    Send(node='grade', arg={'item': 3})
    """

    node: str
    arg: Any


@dataclass(frozen=True)
class Command(Generic[N]):
    """Returned by a node to update state and route in one go, or passed to ``invoke`` to resume an interrupt.

    >>> Command(update={"approved": True}, goto="land")
    Command(update={'approved': True}, goto='land', resume=None, graph=None)
    """

    update: Mapping[str, Any] | None = None
    goto: str | Send | Sequence[str | Send] = ()
    resume: Any = None
    graph: str | None = None

    PARENT: ClassVar[str] = "__parent__"

    def goto_list(self) -> list[str | Send]:
        if isinstance(self.goto, str | Send):
            return [self.goto]
        return list(self.goto)


@dataclass(frozen=True)
class Interrupt:
    """A pause requested by ``interrupt(value)``; ``id`` is what a multi-interrupt resume maps values to."""

    value: Any
    id: str = ""


_NOT_RETRIED = (
    ValueError,
    TypeError,
    ArithmeticError,
    ImportError,
    LookupError,
    NameError,
    SyntaxError,
    RuntimeError,
    ReferenceError,
    StopIteration,
    StopAsyncIteration,
    OSError,
)


def default_retry_on(exc: BaseException) -> bool:
    """LangGraph's rule: retry lost connections and HTTP 5xx answers, and any error that is not a programming
    error or an OS error (bad values, missing keys, timeouts of our own and the like are not retried)."""
    if isinstance(exc, ConnectionError):
        return True
    response = getattr(exc, "response", None)
    status = getattr(response, "status_code", None)
    if isinstance(status, int):
        return status >= 500
    return not isinstance(exc, _NOT_RETRIED)


@dataclass(frozen=True)
class RetryPolicy:
    """How a node is retried when it raises: attempts, exponential backoff with jitter, which exceptions.

    ``retry_on`` is an exception class, a list or tuple of them, or a predicate. The default
    (:func:`default_retry_on`, LangGraph's rule) retries lost connections and HTTP 5xx errors and nothing that
    a retry cannot fix (``ValueError``, ``KeyError``, ``RuntimeError``, ``OSError``, ...).

    >>> RetryPolicy(max_attempts=3, initial_interval=0.1).interval(2, jitter=False)
    0.2
    """

    initial_interval: float = 0.5
    backoff_factor: float = 2.0
    max_interval: float = 128.0
    max_attempts: int = 3
    jitter: bool = True
    retry_on: (
        type[BaseException]
        | tuple[type[BaseException], ...]
        | Sequence[type[BaseException]]
        | Callable[[BaseException], bool]
    ) = default_retry_on

    def __post_init__(self) -> None:
        if isinstance(self.retry_on, list | tuple):
            object.__setattr__(self, "retry_on", tuple(self.retry_on))
        elif not callable(self.retry_on):
            raise ValueError(
                f"RetryPolicy.retry_on must be an exception class, a list of them or a predicate, got {self.retry_on!r}"
            )
        if self.max_attempts < 1:
            raise ValueError(f"RetryPolicy.max_attempts must be >= 1, got {self.max_attempts}")
        if self.initial_interval < 0 or self.backoff_factor < 1:
            raise ValueError("RetryPolicy needs initial_interval >= 0 and backoff_factor >= 1")

    def should_retry(self, exc: BaseException) -> bool:
        retry_on = self.retry_on
        if isinstance(retry_on, type | tuple):
            return isinstance(exc, retry_on)
        predicate = cast(Callable[[BaseException], bool], retry_on)
        return bool(predicate(exc))

    def interval(self, attempt: int, *, jitter: bool | None = None) -> float:
        """Seconds to wait after failed attempt number ``attempt`` (1-based)."""
        base = min(self.max_interval, self.initial_interval * self.backoff_factor ** (attempt - 1))
        if self.jitter if jitter is None else jitter:
            import random

            base += random.uniform(0, 1)
        return base


@dataclass(frozen=True)
class PregelTask:
    """A task scheduled for the next superstep, as shown in a :class:`StateSnapshot`."""

    id: str
    name: str
    path: tuple[Any, ...] = ()
    error: str | None = None
    interrupts: tuple[Interrupt, ...] = ()
    result: Any = None


@dataclass(frozen=True)
class StateSnapshot:
    """The state of a thread at one checkpoint, as returned by ``get_state`` and ``get_state_history``."""

    values: dict[str, Any]
    next: tuple[str, ...]
    config: dict[str, Any]
    metadata: dict[str, Any] = field(default_factory=dict)
    created_at: str | None = None
    parent_config: dict[str, Any] | None = None
    tasks: tuple[PregelTask, ...] = ()

    @property
    def interrupts(self) -> tuple[Interrupt, ...]:
        return tuple(i for t in self.tasks for i in t.interrupts)
