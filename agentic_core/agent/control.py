"""The control port: how a person (the terminal, the console, a test) steers a run from any thread — ``pause``,
``resume``, ``abort``, ``rtl``, ``land`` — and answers the questions the run asks (``approve``/``decline`` with a
reason). The agent loop reads it between steps and while a long flight action flies.

>>> port = ControlPort()
>>> port.pause(by="test")
>>> port.paused, port.stop_requested()
(True, None)
>>> port.rtl(by="test")
>>> port.stop_requested()
'rtl'
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

StopCommand = Literal["abort", "rtl", "land", "hold"]
Command = Literal["pause", "resume", "abort", "rtl", "land", "hold", "approve", "decline"]


@dataclass(frozen=True)
class OperatorAnswer:
    """What the operator said, and how the run reads it."""

    approved: bool
    said: str | None
    why: str
    args: dict[str, Any] | None = None
    """With an approval, the operator's edits to the step's arguments (checked like any others when they fly)."""
    timed_out: bool = False
    """Nobody answered in time (declined, but a question may treat silence otherwise: a swarm's verification)."""


@dataclass
class Question:
    """A question the run waits on (an approval), until answered or timed out."""

    id: str
    request: dict[str, Any]
    asked_s: float = field(default_factory=time.monotonic)
    answer: OperatorAnswer | None = None
    by: str | None = None


Operator = Callable[[dict[str, Any]], OperatorAnswer]
"""Answers one approval request (the terminal, a test's script): called on a thread of its own."""


class ControlPort:
    """Commands and answers for one run; thread-safe. ``on_command`` is told of every command (for the trace)."""

    def __init__(self, on_command: Callable[[str, dict[str, Any]], None] | None = None) -> None:
        self._cond = threading.Condition()
        self._paused = False
        self._stop: StopCommand | None = None
        self._stop_reason: str | None = None
        self._stop_by: str | None = None
        self._questions: dict[str, Question] = {}
        self._ids = itertools.count(1)
        self._on_command = on_command
        self._listeners: list[Callable[[Question], None]] = []
        self._stop_listeners: list[Callable[[], None]] = []

    # ---- the person's side ----

    def pause(self, *, by: str = "operator") -> None:
        """Hold where the aircraft is and start no new step until :meth:`resume`."""
        self._command("pause", by, lambda: setattr(self, "_paused", True))

    def resume(self, *, by: str = "operator") -> None:
        """Go on after :meth:`pause`."""
        self._command("resume", by, lambda: setattr(self, "_paused", False))

    def abort(self, reason: str | None = None, *, by: str = "operator") -> None:
        """End the mission now; the aircraft does what the mission's abort policy says."""
        self._stop_with("abort", reason, by)

    def rtl(self, *, by: str = "operator") -> None:
        """End the mission and return to launch."""
        self._stop_with("rtl", None, by)

    def land(self, *, by: str = "operator") -> None:
        """End the mission and land where the aircraft is."""
        self._stop_with("land", None, by)

    def hold(self, *, by: str = "operator") -> None:
        """End the mission and hold where the aircraft is (a failsafe's ``hold``)."""
        self._stop_with("hold", None, by)

    def approve(
        self,
        question_id: str | None = None,
        reason: str | None = None,
        *,
        by: str = "operator",
        args: dict[str, Any] | None = None,
    ) -> bool:
        """Approve a pending question (the oldest when no id is given), with ``args`` replacing some of the step's
        arguments (the step refuses names it does not have; the envelope checks the values when they fly); False
        when there is none."""
        why = reason or f"approved by {by}" + (" with edits" if args else "")
        return self._answer(question_id, OperatorAnswer(True, reason, why, dict(args) if args else None), by)

    def decline(self, question_id: str | None = None, reason: str | None = None, *, by: str = "operator") -> bool:
        """Decline a pending question (the oldest when no id is given); False when there is none."""
        return self._answer(question_id, OperatorAnswer(False, reason, reason or f"declined by {by}"), by)

    def pending(self) -> list[Question]:
        """The questions waiting for an answer, oldest first."""
        with self._cond:
            return [q for q in self._questions.values() if q.answer is None]

    def on_question(self, listener: Callable[[Question], None]) -> None:
        """Be told of each new question (called in the asking thread)."""
        with self._cond:
            self._listeners.append(listener)

    def on_stop(self, listener: Callable[[], None]) -> None:
        """Be told of each pause or stop command at once, in the commanding thread (the dispatcher wakes, and slows
        the simulation until it has acted: at full speed a poll's 50 ms of wall time is seconds of flight)."""
        with self._cond:
            self._stop_listeners.append(listener)

    def answer_with(self, operator: Operator) -> None:
        """Let ``operator`` answer every question, each on a thread of its own (the terminal, a test's script)."""

        def ask(question: Question) -> None:
            def work() -> None:
                try:
                    answer = operator(dict(question.request))
                except Exception as exc:  # an operator that breaks declines: the safe answer
                    answer = OperatorAnswer(False, None, f"the operator failed ({type(exc).__name__}): declined")
                self._answer(question.id, answer, "operator")

            threading.Thread(target=work, name=f"operator-{question.id}", daemon=True).start()

        self.on_question(ask)

    # ---- the agent's side ----

    @property
    def paused(self) -> bool:
        with self._cond:
            return self._paused

    def stop_requested(self) -> StopCommand | None:
        """abort, rtl, land or hold once one was asked for (the first one stands)."""
        with self._cond:
            return self._stop

    @property
    def stop_reason(self) -> str | None:
        with self._cond:
            return self._stop_reason

    @property
    def stopped_by(self) -> str | None:
        """Who sent the stop command that stands."""
        with self._cond:
            return self._stop_by

    def wait_while_paused(self, poll_s: float = 0.1) -> None:
        """Block while paused, until resumed or a stop command arrives."""
        with self._cond:
            while self._paused and self._stop is None:
                self._cond.wait(poll_s)

    def wait_for_change(self, timeout_s: float) -> None:
        """Block until a command or answer arrives, at most ``timeout_s``."""
        with self._cond:
            self._cond.wait(timeout_s)

    def ask(self, request: dict[str, Any], timeout_s: float) -> OperatorAnswer:
        """Ask a question and wait for its answer; no answer within ``timeout_s`` (or a stop command) declines."""
        with self._cond:
            question = Question(id=f"q{next(self._ids)}", request=dict(request))
            self._questions[question.id] = question
            listeners = list(self._listeners)
        for listener in listeners:
            listener(question)
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while question.answer is None and self._stop is None:
                left = deadline - time.monotonic()
                if left <= 0:
                    question.answer = OperatorAnswer(
                        False, None, f"no answer in {timeout_s:g} s: declined", timed_out=True
                    )
                    question.by = "timeout"
                    break
                self._cond.wait(min(left, 0.5))
            if question.answer is None:
                question.answer = OperatorAnswer(False, None, f"the run was stopped ({self._stop}): declined")
                question.by = "stop"
            del self._questions[question.id]
            return question.answer

    # ---- internals ----

    def _command(self, name: str, by: str, change: Callable[[], None], **detail: Any) -> None:
        with self._cond:
            change()
            self._cond.notify_all()
            stopping = list(self._stop_listeners) if name != "resume" else []
        if self._on_command is not None:  # first: the trace tells of the command before of what it caused
            self._on_command(name, {"by": by, **detail})
        for listener in stopping:
            listener()

    def _stop_with(self, command: StopCommand, reason: str | None, by: str) -> None:
        def change() -> None:
            if self._stop is None:
                self._stop, self._stop_reason, self._stop_by = command, reason, by

        self._command(command, by, change, **({"reason": reason} if reason else {}))

    def _answer(self, question_id: str | None, answer: OperatorAnswer, by: str) -> bool:
        with self._cond:
            waiting = [q for q in self._questions.values() if q.answer is None]
            chosen = (
                next((q for q in waiting if q.id == question_id), None) if question_id else next(iter(waiting), None)
            )
            if chosen is None:
                return False
            chosen.answer, chosen.by = answer, by
            self._cond.notify_all()
        if self._on_command is not None:
            verb = "approve" if answer.approved else "decline"
            edits = {"args": answer.args} if answer.args else {}
            self._on_command(verb, {"by": by, "question": chosen.id, "step": chosen.request.get("step"),
                                    "reason": answer.said, **edits})  # fmt: skip
        return True


__all__ = ["Command", "ControlPort", "Operator", "OperatorAnswer", "Question", "StopCommand"]
