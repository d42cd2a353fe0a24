"""A run's trace: one JSON object per line for everything that happened — graph nodes, tool calls, model calls,
decisions, triggers, approvals — each stamped with wall and simulated time.

Thread-safe (the vehicle thread, the mission and the tools all write to it) and flushed line by line, so a crashed
run leaves its trace up to the crash.

>>> import io, json
>>> out = io.StringIO()
>>> trace = TraceWriter(out, sim_clock=lambda: 12.5)
>>> trace.write("tool", name="flight.takeoff", status="ok")
>>> record = json.loads(out.getvalue())
>>> record["kind"], record["sim_t"], record["name"]
('tool', 12.5, 'flight.takeoff')
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO


class TraceWriter:
    """Appends trace records to a file (or any text stream) and keeps them for the report."""

    def __init__(
        self,
        out: Path | TextIO,
        *,
        sim_clock: Callable[[], float] | None = None,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self._own = isinstance(out, Path)
        self._out: TextIO = out.open("a", encoding="utf-8") if isinstance(out, Path) else out
        self._sim_clock = sim_clock
        self._clock = clock
        self._lock = threading.Lock()
        self.records: list[dict[str, Any]] = []

    def write(self, kind: str, **fields: Any) -> None:
        """One record: ``kind`` (run, node, tool, llm, decision, trigger, approval, log, ...) and its fields."""
        record: dict[str, Any] = {"t": round(self._clock(), 6), "kind": kind}
        if self._sim_clock is not None:
            record["sim_t"] = round(self._sim_clock(), 3)
        record.update(fields)
        line = json.dumps(record, ensure_ascii=False, default=str)
        with self._lock:
            self.records.append(json.loads(line))
            self._out.write(line + "\n")
            self._out.flush()

    def of_kind(self, kind: str) -> list[dict[str, Any]]:
        with self._lock:
            return [r for r in self.records if r["kind"] == kind]

    def close(self) -> None:
        with self._lock:
            if self._own and not self._out.closed:
                self._out.close()


__all__ = ["TraceWriter"]
