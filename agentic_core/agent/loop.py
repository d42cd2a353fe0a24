"""The agent loop: drives a compiled mission graph to its end — pulling its supersteps, following what each node
changed (published as events), pausing and stopping on the control port, asking the operator the questions the
mission paused for (``interrupt``) and resuming the graph from its checkpoint with the answers.

The paper's loop — tier-1 trigger, tier-2 assessment, plan, validate, splice, act, reflect — is the mission graph
(:mod:`agentic_core.mission.compile`: the scheduler fires triggers and splices plans, the reflect node revises
failures) plus the parts here: :class:`~agentic_core.agent.gate.Gate` (tier 2) and
:class:`~agentic_core.agent.dispatch.Dispatcher` (act, and the watch during long actions).

One thread runs it: the caller's. The graph runs the steps of a superstep on its worker threads; flight actions
being watched run on a thread of their own while the dispatching thread watches.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from ..graph import Command, CompiledStateGraph
from .control import ControlPort, OperatorAnswer, StopCommand
from .pacing import Pace
from .ports import Publish

REFUSALS = frozenset({"plan rejected", "revision rejected", "plan failed", "not fired"})
"""Mission log entries that refuse a model's plan (or a firing): published as ``refusal`` with every reason."""

MISSION_EVENTS = frozenset(
    {"fired", "declined", "planned", "plan empty", "replaced", "reflection gave up", "interrupted", "skipped"}
)
"""Other mission log entries worth an event."""

TIME_LIMIT = "the wall-clock limit"
"""Who asks for the return of a run past its ``max_wall_s``, on the control port, so that a step that is still
going (a ``wait_until`` that never comes true, a long hover) gives way too, not only the next superstep."""


@dataclass
class LoopResult:
    """How the graph ended: its final state, and whether it was stopped (by the operator, or by the wall clock)."""

    state: dict[str, Any] = field(default_factory=dict)
    stopped: StopCommand | None = None
    over_time: bool = False


class AgentLoop:
    """Runs one mission graph (one thread: the caller's)."""

    def __init__(
        self,
        graph: CompiledStateGraph,
        config: Mapping[str, Any],
        *,
        control: ControlPort,
        publish: Publish,
        pace: Pace,
        ask: bool,
        approval_timeout_s: float = 120.0,
        max_wall_s: float = 900.0,
        after_update: Callable[[], None] | None = None,
    ) -> None:
        self.graph = graph
        self.config = dict(config)
        self.control = control
        self.publish = publish
        self.pace = pace
        self.ask = ask
        self.approval_timeout_s = approval_timeout_s
        self.max_wall_s = max_wall_s
        self.after_update = after_update

    def run(self, inputs: Any) -> LoopResult:
        """Run from ``inputs`` (the initial state; None to go on from the checkpoint) to the end or a stop."""
        wall0 = time.monotonic()
        result = LoopResult()
        limit = threading.Timer(max(self.max_wall_s, 0.0), self.control.rtl, kwargs={"by": TIME_LIMIT})
        limit.daemon = True
        limit.start()
        try:
            self._drive(inputs, wall0, result)
        finally:
            limit.cancel()
        result.stopped = self.control.stop_requested()
        if self.control.stopped_by == TIME_LIMIT:
            result.over_time, result.stopped = True, None
        result.state = dict(self.graph.get_state(self.config).values)
        return result

    def _drive(self, inputs: Any, wall0: float, result: LoopResult) -> None:
        """Stream the graph until it ends, a stop, or past ``max_wall_s`` between supersteps."""
        while True:
            for update in self.graph.stream(inputs, self.config, stream_mode="updates"):
                for node, change in update.items():
                    if isinstance(change, dict):
                        self.follow(node, change)
                if self.after_update is not None:
                    self.after_update()
                if time.monotonic() - wall0 > self.max_wall_s:
                    result.over_time = True
                    break
                if self._paused_or_stopped():
                    break
            if result.over_time or self.control.stop_requested():
                break
            pending = self.graph.get_state(self.config).interrupts
            if not pending:
                break
            inputs = Command(resume={i.id: self.question(dict(i.value)) for i in pending})
            if self.control.stop_requested():
                break

    def _paused_or_stopped(self) -> bool:
        """Between supersteps: wait out a pause; True when the run must stop streaming (a stop command)."""
        if self.control.paused:
            self.publish("log", level="info", summary="paused: holding until resumed")
            with self.pace.waiting("operator"):
                self.control.wait_while_paused()
            if self.control.stop_requested() is None:
                self.publish("log", level="info", summary="resumed")
        return self.control.stop_requested() is not None

    def question(self, request: dict[str, Any]) -> bool | dict[str, Any]:
        """A step waits for the operator: ask on the control port (the simulation at real time meanwhile); the
        answer, or ``{"approve": True, "args": edits}`` when the operator approved with edited arguments."""
        self.publish("approval", request=request, status="asked", summary=f"asked: {request.get('question')}")
        with self.pace.waiting("operator"):
            answer: OperatorAnswer = self.control.ask(request, self.approval_timeout_s)
        edits = {"edited": answer.args} if answer.approved and answer.args else {}
        self.publish("approval", request=request, answer=answer.approved, via="operator", said=answer.said, **edits,
                     summary=f"{request.get('step')}: {answer.why}")  # fmt: skip
        return {"approve": True, "args": answer.args} if edits else answer.approved

    def follow(self, node: str, change: Mapping[str, Any]) -> None:
        """Publish what one node changed: step statuses, and the mission's log of triggers, plans and refusals."""
        errors = change.get("errors") or {}
        for step, status in (change.get("status") or {}).items():
            why = errors.get(step) if status in ("failed", "skipped") else None
            extra = {"error": why} if why else {}
            self.publish("step", node=node, step=step, status=status, **extra,
                         summary=f"{step} {status}" + (f": {why}" if why else ""))  # fmt: skip
        for entry in change.get("log") or []:
            status = str(entry.get("status"))
            if status in REFUSALS:
                self.publish("refusal", **entry, summary=f"{entry.get('step')}: {status}: {entry.get('error')}")
            elif status in MISSION_EVENTS:
                self.publish("mission", **entry, summary=f"{entry.get('step')}: {status}")


def policy_approval(approve: bool, publish: Publish) -> Callable[[dict[str, Any]], bool]:
    """The headless answer to every approval (``--approval approve|decline``), published like an operator's."""

    def answer(request: dict[str, Any]) -> bool:
        verdict = "approved" if approve else "declined"
        publish("approval", request=request, answer=approve, via="policy",
                summary=f"{request.get('step')}: {verdict} (headless policy)")  # fmt: skip
        return approve

    return answer


__all__ = ["MISSION_EVENTS", "REFUSALS", "AgentLoop", "LoopResult", "policy_approval"]
