"""The run's fault schedule: the faults a user wrote (``--fault battery=18%@S1``, a scene's ``faults:``) delivered
to the vehicle when they fall due, through ``flight.inject_failure`` (MAV_CMD_INJECT_FAILURE after
``SYS_FAILURE_EN``), so they work on a connected vehicle as on the simulator.

A timed fault falls due on telemetry (mission time: the vehicle's clock since the run's first sample); a step's
fault when the bus says the step completed (``step`` event, status ``ok``). Both are noticed in other threads (the
vehicle's, the agent loop's) that must not wait for the vehicle's answer, so one thread of this schedule
(``fault-schedule``, :meth:`FaultSchedule.start` to :meth:`FaultSchedule.close`) delivers them in order. Each is a
``fault`` event with the vehicle's answer; a fault the trace of a resumed run shows delivered is not sent again.

>>> from agentic_core.contracts.faults import parse_fault
>>> from agentic_core.contracts.tool_result import ToolResult
>>> sent, said = [], []
>>> def call(name, args):
...     sent.append(args)
...     return ToolResult(call_id="c1", tool=name, status="ok", latency_s=0.0, attempts=1)
>>> schedule = FaultSchedule([parse_fault("gps_loss@t=5s")], call, lambda kind, **f: said.append(f["summary"]))
>>> schedule.deliver(parse_fault("gps_loss@t=5s"))
>>> sent, said
([{'fault': 'gps_loss'}], ['fault gps_loss@t=5s injected'])
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

from tools import Caller

from ..agent.ports import Publish
from ..contracts import RunEvent, TelemetrySample
from ..contracts.faults import Fault
from ..contracts.tool_result import ToolResult

SCHEDULE = Caller(id="fault-schedule", scopes=frozenset({"flight:fault"}))
"""Who injects the faults: the one holder of ``flight:fault``, which the agent never holds."""
INJECT = "flight.inject_failure"

Call = Callable[[str, Mapping[str, Any]], ToolResult]


class FaultSchedule:
    """Faults waiting for their time or step; :meth:`on_sample` and :meth:`on_event` notice them."""

    def __init__(self, faults: Sequence[Fault], call: Call, publish: Publish, *, delivered: Iterable[str] = ()):
        done = set(delivered)
        self.waiting = [f for f in faults if f.text() not in done]
        self.call = call
        self.publish = publish
        self._lock = threading.Lock()
        self._queue: queue.Queue[Fault | None] = queue.Queue()
        self._t0: float | None = None
        self._thread: threading.Thread | None = None

    def on_sample(self, sample: TelemetrySample) -> None:
        """A telemetry hook: queue the timed faults that have fallen due."""
        if self._t0 is None:
            self._t0 = sample.time_s
        elapsed = sample.time_s - self._t0
        self._take(lambda f: f.at_s is not None and elapsed >= f.at_s)

    def on_event(self, event: RunEvent) -> None:
        """A bus subscriber: queue the faults of a step that has completed."""
        if event.kind != "step" or not self.waiting:
            return
        fields = event.fields()
        if fields.get("status") == "ok":
            step = fields.get("step")
            self._take(lambda f: f.at_step is not None and f.at_step == step)

    def _take(self, due: Callable[[Fault], bool]) -> None:
        if not self.waiting:
            return
        with self._lock:
            now = [f for f in self.waiting if due(f)]
            self.waiting = [f for f in self.waiting if f not in now]
        for fault in now:
            self._queue.put(fault)

    def start(self) -> None:
        """Start delivering (the ``fault-schedule`` thread), when there is anything to deliver."""
        if self.waiting and self._thread is None:
            self._thread = threading.Thread(target=self._work, name="fault-schedule", daemon=True)
            self._thread.start()

    def close(self) -> None:
        """Stop delivering (faults still waiting are reported as not delivered). Safe to call twice."""
        thread, self._thread = self._thread, None
        if thread is not None:
            self._queue.put(None)
            thread.join(timeout=10.0)
        with self._lock:
            left, self.waiting = self.waiting, []
        for fault in left:
            self.publish("fault", fault=fault.text(), status="not_due",
                         summary=f"fault {fault.text()} never fell due")  # fmt: skip

    def _work(self) -> None:
        while (fault := self._queue.get()) is not None:
            self.deliver(fault)

    def deliver(self, fault: Fault) -> None:
        """Inject one fault now and say what the vehicle answered."""
        args: dict[str, Any] = {"fault": fault.fault}
        if fault.value is not None:
            args["value"] = fault.value
        result = self.call(INJECT, args)
        said = "injected" if result.status == "ok" else f"not injected: {result.error}"
        self.publish("fault", fault=fault.text(), status=result.status, error=result.error,
                     summary=f"fault {fault.text()} {said}")  # fmt: skip


__all__ = ["INJECT", "SCHEDULE", "FaultSchedule"]
