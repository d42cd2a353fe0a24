"""A run's records on disk: ``trace.jsonl`` (every :class:`~agentic_core.contracts.RunEvent` of the bus, one per
line) and ``telemetry.jsonl`` (the vehicle's telemetry samples at a fixed rate of its clock, 10 Hz by default).

Both are flushed line by line, so a killed run leaves them up to the kill; a resumed run appends.

>>> import io, json
>>> from agentic_core.agent.bus import EventBus
>>> out = io.StringIO()
>>> bus = EventBus(clock=lambda: 12.5)
>>> trace = TraceWriter(out)
>>> _ = bus.subscribe(trace)
>>> _ = bus.publish("tool", name="flight.takeoff", status="ok")
>>> record = json.loads(out.getvalue())
>>> record["kind"], record["sim_t"], record["name"], record["seq"]
('tool', 12.5, 'flight.takeoff', 1)
"""

from __future__ import annotations

import json
import math
import threading
from pathlib import Path
from typing import Any, TextIO

from ..contracts import RunEvent, TelemetrySample


class TraceWriter:
    """A bus subscriber that appends each event to a file (or a text stream) and keeps them for the report."""

    def __init__(self, out: Path | TextIO) -> None:
        self._own = isinstance(out, Path)
        self._out: TextIO = _append(out) if isinstance(out, Path) else out
        self._lock = threading.Lock()
        self.records: list[dict[str, Any]] = []

    def __call__(self, event: RunEvent) -> None:
        line = event.model_dump_json(exclude_none=False)
        record = json.loads(line)
        with self._lock:
            if self._out.closed:
                return
            self.records.append(record)
            self._out.write(line + "\n")
            self._out.flush()

    def of_kind(self, kind: str) -> list[dict[str, Any]]:
        with self._lock:
            return [r for r in self.records if r["kind"] == kind]

    def close(self) -> None:
        with self._lock:
            if self._own and not self._out.closed:
                self._out.close()


class TelemetryLog:
    """A sample hook that writes one JSON line per ``1 / hz`` seconds of the vehicle's clock (10 Hz by default)."""

    def __init__(self, path: Path, hz: float = 10.0) -> None:
        if not hz > 0:
            raise ValueError("hz must be positive")
        self.period_s = 1.0 / hz
        self._out = _append(path)
        self._next_period = -(2**62)
        self._lock = threading.Lock()
        self.last: TelemetrySample | None = None
        self.lines = 0

    def __call__(self, sample: TelemetrySample) -> None:
        self.last = sample
        with self._lock:
            period = math.floor(sample.time_s / self.period_s + 1e-6)  # the period the sample falls in
            if self._out.closed or period < self._next_period:
                return
            self._next_period = period + 1
            self._out.write(sample.model_dump_json() + "\n")
            self._out.flush()
            self.lines += 1

    def close(self) -> None:
        with self._lock:
            if not self._out.closed:
                self._out.close()


def _append(path: Path) -> TextIO:
    """``path`` opened to append, on a fresh line: a last line cut short by a kill is left as it is, not joined."""
    if path.is_file() and path.stat().st_size:
        with path.open("rb") as existing:
            existing.seek(-1, 2)
            cut = existing.read(1) != b"\n"
    else:
        cut = False
    out = path.open("a", encoding="utf-8")
    if cut:
        out.write("\n")
    return out


__all__ = ["TelemetryLog", "TraceWriter"]
