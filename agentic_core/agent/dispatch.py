"""The mission's one way to act (``Environment.dispatch``): every step's tool call goes through the tools executor
from here, with

* an idempotency key made of the run, the step (its path, pass, attempt and call number) so a resumed run does not
  repeat a side effect (the executor replays the recorded result);
* the flight envelope (:mod:`~agentic_core.agent.envelope`): a command outside the mission's limits, once
  resolved, is refused (``denied``, with every reason) and never sent;
* pacing: the simulation runs at full speed while a flight action flies and at real time while anything else is
  awaited;
* the watch during a long flight action (``flight.fly_to``, ``orbit``, ``hover``): the control port (pause, abort,
  rtl, land) and the triggers' rules, evaluated on the mission state the step started from (during ``takeoff``,
  ``land``, ``rtl`` and ``start_mission``, and during every flight action of a trigger's own sub-plan, the control
  port alone: a pause or a stop holds the aircraft at once, unless the stop asks for what the action does already,
  an ``rtl`` during a return or a ``land`` during a descent). When a rule holds for an object the reasoner has not
  judged, the aircraft goes to hold over it (``hold_over`` names where; else it holds where it is) while the
  reasoner thinks, so the object stays in view however slow the model; if the reasoner lets the trigger act the
  action ends :class:`~agentic_core.mission.steps.Interrupted` with the trigger latched on the object, else the
  action is sent again and flies on.

Every call and every interruption is published as a ``tool`` event.
"""

from __future__ import annotations

import inspect
import threading
import uuid
from collections.abc import Callable, Mapping
from typing import Any

from tools import ToolExecutor, ToolResult

from ..contracts.policy_graph import ON_ABORT_TOOLS, OnAbort
from ..mission.model import Trigger
from ..mission.steps import Interrupted, current_call
from .control import ControlPort
from .envelope import Envelope
from .gate import Gate
from .pacing import Pace
from .ports import Publish, VehicleView

WATCHED_TOOLS = frozenset({"flight.fly_to", "flight.orbit", "flight.hover"})
"""Long flight actions during which the control port and the triggers are watched."""
CONTROLLED_TOOLS = frozenset({"flight.takeoff", "flight.land", "flight.rtl", "flight.start_mission"})
"""Long flight actions during which only the control port is watched: a stop or a pause ends them with a hold at
once (a take-off climbs for tens of seconds, a landing or a return for a minute or more, a MAVLink mission may fly
for an hour). The triggers wait for the next barrier: sent again after a declined trigger, a take-off would be
refused in the air, a mission start over, and a trigger's rule must not turn back a return or a landing. A trigger's
own sub-plan is watched this way too, whatever its flight actions."""
LAND = "flight.land"
DESCENDS = frozenset({LAND, "flight.rtl"})
"""The actions that end in a descent to land, which a ``land`` stop lets go on once it has begun (before it, they
fly elsewhere)."""
FAILSAFE = "failsafe"
"""Who a telemetry failsafe's stop is by (:mod:`~agentic_core.agent.failsafes`)."""

VEHICLE_WAITS = ("flight.", "swarm.")
"""Tools whose wait is a wait on vehicles (its own, or the swarm's flying a task): the simulation runs at full speed."""
HOLD = "flight.hold"
HOLD_WAIT_S = 2.0
"""How long a hold is given to end the action it supersedes before another is sent."""

Watch = Callable[[Mapping[str, Any]], list[tuple[Trigger, Any]]]
"""The (trigger, event) pairs whose rule holds now, evaluated on a mission state."""

Prepare = Callable[[dict[str, Any]], dict[str, Any]]


class Dispatcher:
    """``Environment.dispatch`` for one run."""

    def __init__(
        self,
        executor: ToolExecutor,
        *,
        run_id: str,
        gate: Gate,
        control: ControlPort,
        pace: Pace,
        publish: Publish,
        watch: Watch | None = None,
        prepare: Mapping[str, Prepare] | None = None,
        hold_over: Callable[[Any], dict[str, Any] | None] | None = None,
        envelope: Envelope | None = None,
        poll_s: float = 0.05,
        on_abort: OnAbort | None = None,
        vehicle: VehicleView | None = None,
    ) -> None:
        self.executor = executor
        self.run_id = run_id
        self.gate = gate
        self.control = control
        self.pace = pace
        self.publish = publish
        self.watch = watch
        self.prepare = dict(prepare or {})
        self.hold_over = hold_over
        self.envelope = envelope
        self.poll_s = poll_s
        self.on_abort = on_abort
        """The mission's ``on_abort``: an abort lets a return (``rtl``) or a descent (``land``) under way go on as
        that says (unknown: it holds, and the run's stop does the rest)."""
        self.vehicle: VehicleView = vehicle if vehicle is not None else gate.vehicle
        """The vehicle's telemetry, read to tell a descent from the flight to where it lands."""
        self.frame_driven = False
        """Set when perception calls :meth:`spot` after every frame: the watch then looks in lockstep with the
        camera, not at the dispatcher's polls."""
        self._watch_lock = threading.Lock()
        self._watching: Mapping[str, Any] | None = None
        self._spotted: tuple[Trigger, Any] | None = None
        self._flying = False
        """A watched or controlled action is in the air, the dispatcher waiting on it (under ``_watch_lock``)."""
        self._wake = threading.Event()
        """Set when that action ends or the operator sends a pause or stop: the wait ends at once."""
        self._keyed = "idempotency_key" in inspect.signature(executor.call).parameters
        control.on_stop(self._heard)

    def __call__(self, tool: str, args: dict[str, Any], timeout_s: float | None) -> ToolResult | Interrupted:
        if tool in self.prepare:
            args = self.prepare[tool](args)
        call = current_call()
        key = f"{self.run_id}:{call.key()}" if call is not None else None
        state = call.state if call is not None else None
        if tool in WATCHED_TOOLS and state is not None and not state.get("preempted_by"):
            return self._watched(tool, args, timeout_s, state, key)
        if tool in WATCHED_TOOLS or tool in CONTROLLED_TOOLS:
            return self._controlled(tool, args, timeout_s, key)
        return self.call(tool, args, timeout_s, key=key)

    def call(
        self,
        tool: str,
        args: dict[str, Any],
        timeout_s: float | None = None,
        *,
        key: str | None = None,
        publish: bool = True,
    ) -> ToolResult:
        """One tool call through the executor, paced, keyed with ``key`` (an idempotency key) and published (unless
        the caller publishes it itself)."""  # fmt: skip
        options: dict[str, Any] = {"timeout_s": timeout_s}
        if key is not None and self._keyed:
            options["idempotency_key"] = key
        problems = self.envelope.check(tool, args) if self.envelope is not None else []
        if problems:
            result = _refused(tool, problems)
        else:
            with self.pace.waiting("vehicle" if tool.startswith(VEHICLE_WAITS) else "tool"):
                result = self.executor.call(tool, args, **options)
        if publish:
            self.published(tool, args, result, key)
        return result

    def published(self, tool: str, args: dict[str, Any], result: ToolResult, key: str | None) -> None:
        """Publish one call's ``tool`` event."""
        replayed = bool(getattr(result, "replayed", False))
        self.publish(
            "tool", name=tool, args=args, status=result.status, error=result.error, latency_s=result.latency_s,
            key=key, replayed=replayed, **_delivery(result),
            summary=f"{tool} {result.status}" + (" (replayed)" if replayed else "")
            + (f": {result.error}" if result.error else ""),
        )  # fmt: skip

    def _watched(
        self, tool: str, args: dict[str, Any], timeout_s: float | None, state: Mapping[str, Any], key: str | None
    ) -> ToolResult | Interrupted:
        while True:
            already = self.stopping()
            if already is not None:  # never start a movement the operator has already stopped: hold where it is
                return self._interrupted(tool, self.executor.call(HOLD, {}), Interrupted(already))
            with self._watch_lock:
                self._watching, self._spotted, self._flying = state, None, True
                self._take_off()
            worker = self._flight(lambda: self.call(tool, args, timeout_s, key=key, publish=False), f"agent-{tool}")
            found: tuple[Trigger, Any] | None = None
            stop: str | None = None
            try:
                while worker.running(self.poll_s):
                    stop = self.stopping()
                    if stop is not None:
                        break
                    found = self._take_spotted() if self.frame_driven else self._new_event(state)
                    if found is not None:
                        break
                if stop is None and found is None:
                    result = worker.result()
                    self.published(tool, args, result, key)
                    return result
                hold = self._stop(worker)  # the action ends, superseded by the hold: its result is the interruption's
                if stop is not None:  # traced while the world still crawls: at the simulated moment the action ended
                    return self._interrupted(tool, hold, Interrupted(stop))
            finally:
                with self._watch_lock:
                    self._watching, self._flying = None, False
                    self.pace.urgent(False)
            assert found is not None
            trigger, event = found
            over = self._go_over(event)
            acted = self.gate(trigger, event)  # the aircraft holds over the object while the reasoner thinks
            if over is not None:
                self._stop(over)  # before anything else is sent: its command must not land after the next one
            if acted:
                reason = f"{trigger.id} acts on {_name(event)}"
                return self._interrupted(tool, hold, Interrupted(reason, trigger=trigger.id, event=event))
            self.publish("tool", name=tool, status="resumed", summary=f"{tool} flies on: {trigger.id} declined")

    def _controlled(
        self, tool: str, args: dict[str, Any], timeout_s: float | None, key: str | None
    ) -> ToolResult | Interrupted:
        """A :data:`CONTROLLED_TOOLS` action (or any long one of a trigger's sub-plan) on a thread of its own, the
        control port watched while it flies: a pause or a stop holds the aircraft and ends it interrupted, unless
        the stop asks for what it does already (:meth:`_goes_on`)."""
        with self._watch_lock:
            self._flying = True
            self._take_off()
        try:
            worker = self._flight(lambda: self.call(tool, args, timeout_s, key=key, publish=False), f"agent-{tool}")
            goes_on = False
            while worker.running(self.poll_s):
                if goes_on:  # the first stop stands: a later command changes nothing, nor slows the world
                    self.pace.urgent(False)
                    continue
                stop = self.stopping()
                if stop is None:
                    continue
                if self._goes_on(tool):
                    goes_on = True
                    self.pace.urgent(False)
                    self.publish("log", level="info", summary=f"{tool} goes on: {stop}, as it does already")
                    continue
                return self._interrupted(tool, self._stop(worker), Interrupted(stop))
        finally:
            with self._watch_lock:
                self._flying = False
                self.pace.urgent(False)
        result = worker.result()
        self.published(tool, args, result, key)
        return result

    def _goes_on(self, tool: str) -> bool:
        """The standing stop asks for what ``tool`` is doing already, so letting it go on does what the stop asks
        without a hold in between: an ``rtl`` during a return; a ``land`` during a descent to land (a landing's,
        or a return's last); an ``abort`` as the mission's ``on_abort`` says (unknown, it holds). A failsafe never
        turns back a landing's descent (as PX4's own do not: landing is the safer action). A landing still flying
        to where it would land holds, and a ``land`` stop lands it there."""
        command = self.control.stop_requested()
        wanted = command if command != "abort" else self.on_abort
        descending = tool in DESCENDS and self.vehicle.view().get("landed_state") == "landing"
        if wanted == "land" or (tool == LAND and self.control.stopped_by == FAILSAFE):
            return descending
        return wanted is not None and ON_ABORT_TOOLS.get(wanted) == tool and tool != LAND

    def _flight(self, action: Callable[[], ToolResult], name: str) -> _Flight:
        return _Flight(action, name, self._wake)

    def _take_off(self) -> None:
        """An action is about to be sent (under ``_watch_lock``). A stop or pause that came since the last look is
        seen at the first poll, once the action is on its way (the hold must supersede it); until then the world
        crawls."""
        self._wake.clear()
        if self.stopping() is not None:
            self.pace.urgent(True)

    def _heard(self) -> None:
        """The operator sent a pause or a stop (any thread): while an action flies, slow the simulation until the
        hold is sent, and wake the wait at once."""
        with self._watch_lock:
            if self._flying:
                self.pace.urgent(True)
        self._wake.set()

    def _stop(self, flight: _Flight) -> ToolResult:
        """Send ``flight.hold`` until ``flight``'s action has ended (a command still on its way when the first hold
        was sent is superseded by the next); the last hold's result."""
        while True:
            hold = self.executor.call(HOLD, {})
            if not flight.running(HOLD_WAIT_S):
                return hold

    def _go_over(self, event: Any) -> _Flight | None:
        """Send the aircraft to hold over the event's object, without waiting for it to get there: the reasoner
        thinks meanwhile. None when there is nowhere to go (it holds where it is)."""
        args = self.hold_over(event) if self.hold_over is not None else None
        if args is None:
            return None
        return _Flight(lambda: self.call("flight.fly_to", args), "agent-hold-over")

    def stopping(self) -> str | None:
        """Why the run is paused or being stopped by the operator (the control port), None to go on."""
        command = self.control.stop_requested()
        if command is not None:
            by = self.control.stopped_by
            who = (
                "the operator" if by in (None, "operator", "console") else by if by.startswith("the ") else f"the {by}"
            )
            return f"{who} asked to {command}"
        if self.control.paused:
            return "paused by the operator"
        return None

    def spot(self, *_: Any) -> None:
        """After a camera frame (perception's thread, in lockstep with the simulation): look for an event the
        reasoner has not judged while a watched action flies; when there is one, keep it for the watch and slow the
        simulation until the aircraft is told to hold."""
        with self._watch_lock:
            state = self._watching
            if state is None or self._spotted is not None:
                return
        found = self._new_event(state)
        if found is None:
            return
        with self._watch_lock:
            if self._watching is state and self._spotted is None:
                self._spotted = found
                self.pace.urgent(True)
                self._wake.set()

    def _take_spotted(self) -> tuple[Trigger, Any] | None:
        with self._watch_lock:
            found, self._spotted = self._spotted, None
            return found

    def _new_event(self, state: Mapping[str, Any]) -> tuple[Trigger, Any] | None:
        """The first (trigger, event) the watch finds that the reasoner has not judged yet."""
        if self.watch is None:
            return None
        for trigger, event in self.watch(state):
            if not self.gate.known(trigger.id, event):
                return trigger, event
        return None

    def _interrupted(self, tool: str, hold: ToolResult, outcome: Interrupted) -> Interrupted:
        self.publish("tool", name=tool, status="interrupted", trigger=outcome.trigger, hold=hold.status,
                     summary=f"{tool} stopped: {outcome.reason}")  # fmt: skip
        return outcome


def _delivery(result: ToolResult) -> dict[str, Any]:
    """How an alert went out (``delivered_via``: smtp, outbox, webhook, log), for the outcome's accounting."""
    via = result.output.get("delivered_via") if isinstance(result.output, dict) else None
    return {"delivered_via": via} if isinstance(via, str) else {}


def _refused(tool: str, problems: list[str]) -> ToolResult:
    """The result of a command the envelope refused: never sent, and the agent reads why."""
    return ToolResult(
        status="denied", error="outside the flight envelope: " + "; ".join(problems), latency_s=0.0, attempts=0,
        call_id=f"envelope-{uuid.uuid4().hex[:12]}", tool=tool,
    )  # fmt: skip


class _Flight:
    """A flight action running on a thread of its own while the dispatcher watches; what it raised is re-raised
    to the watcher (the step then fails as any raising dispatch does)."""

    def __init__(self, action: Callable[[], ToolResult], name: str, wake: threading.Event | None = None) -> None:
        self._box: dict[str, Any] = {}
        self._wake = wake or threading.Event()
        self._ended = threading.Event()

        def run() -> None:
            try:
                self._box["result"] = action()
            except BaseException as exc:  # handed to the watcher
                self._box["error"] = exc
            finally:
                self._ended.set()
                self._wake.set()

        self._thread = threading.Thread(target=run, name=name, daemon=True)
        self._thread.start()

    def running(self, wait_s: float) -> bool:
        """Wait up to ``wait_s`` for the action to end, or until ``wake`` is set (the operator spoke, the watch saw
        something); whether it still runs."""
        self._wake.wait(wait_s)
        self._wake.clear()
        if self._ended.is_set():
            self._thread.join()
            return False
        return True

    def result(self) -> ToolResult:
        if "error" in self._box:
            raise self._box["error"]
        result: ToolResult = self._box["result"]
        return result


def _name(event: Any) -> str:
    found = event.get("id") if isinstance(event, Mapping) else getattr(event, "id", None)
    return str(found) if found is not None else "the event"


__all__ = ["CONTROLLED_TOOLS", "HOLD", "LAND", "WATCHED_TOOLS", "Dispatcher", "Prepare", "Watch"]
