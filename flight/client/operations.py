"""Operations: one motion command under way at a time, awaited until the vehicle's state says it is done.

Why: an action's ACK only says the vehicle took the command; whether it then *did* it is seen in the telemetry,
and a newer command, a failsafe or another client can interrupt it. :class:`OperationsClient` tracks the one
operation under way (a newer one supersedes it), waits for a predicate over the telemetry with
:meth:`OperationsClient._fly_wait`, and builds the :class:`~flight.client.results.FlightResult` every action
returns, with the state observed at its end.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_RESULT_DENIED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
)

from flight.client.commands import Ack, CommandClient
from flight.client.results import CommandStatus, FlightResult
from flight.client.telemetry import TelemetryState

FLYING_MODES = frozenset({"hold", "takeoff", "position", "orbit"})
"""Modes in which a go-to, take-off, orbit or hover is still being flown; a switch to any other (RTL, Land: a
failsafe, or another client) interrupts it."""


WALL_SLACK = 20.0
"""How many times its budget of the vehicle's time an action may take in wall time (a frozen vehicle's bound)."""
OUT_OF_TIME = "out of the vehicle's time"
LINK_GONE = "the link is gone"


@dataclass(eq=False, slots=True)
class Operation:
    """A motion command under way; a newer one supersedes it."""

    action: str
    started: float
    start_mode: str
    text_mark: int
    superseded_by: str | None = None
    left_start_mode: bool = False


class OperationsClient(CommandClient):
    """The bookkeeping shared by every action that flies or waits for the vehicle."""

    _op: Operation | None = None

    def _begin(self, action: str) -> Operation:
        """Start a motion command: the one under way (if any) is superseded by it."""
        with self._lock:
            if self._op is not None:
                self._op.superseded_by = action
            self._op = Operation(action, time.monotonic(), self._state.mode, self._state.text_count)
            return self._op

    def _end(self, op: Operation) -> None:
        with self._lock:
            if self._op is op:
                self._op = None

    def _result(
        self,
        op: Operation,
        status: CommandStatus,
        *,
        reason: str | None = None,
        reached: bool | None = None,
        ack: int | None = None,
    ) -> FlightResult:
        self._end(op)
        return FlightResult(
            action=op.action,
            status=status,
            reason=reason,
            reached=reached,
            ack=ack,
            elapsed_s=time.monotonic() - op.started,
            state=self.telemetry,
        )

    def _refused(self, op: Operation, ack: Ack) -> FlightResult:
        status: CommandStatus
        if ack.result is None:
            status = "timeout"
        elif ack.result in (MAV_RESULT_DENIED, MAV_RESULT_TEMPORARILY_REJECTED):
            status = "denied"
        elif ack.result == MAV_RESULT_UNSUPPORTED:
            status = "unsupported"
        else:
            status = "failed"
        return self._result(op, status, reason=ack.reason, ack=ack.result)

    async def _wait_on_vehicle_clock(self, check: Callable[[Any], Any], timeout_s: float, start: float | None) -> Any:
        """:meth:`_wait` for ``check``, in one-second slices: it ends when ``check`` answers, when ``timeout_s`` of
        wall time has passed with the vehicle's clock standing still (a vehicle that stopped), when nothing at all
        has been heard from the vehicle for ``link_silent_s`` (:data:`LINK_GONE`: its link is gone), or after
        :data:`WALL_SLACK` × ``timeout_s`` of wall time in any case; without a vehicle clock, after ``timeout_s``."""
        loop = asyncio.get_running_loop()
        now = loop.time()
        deadline = now + timeout_s * (WALL_SLACK if start is not None else 1.0)
        last_clock, last_progress = start, now
        while True:
            outcome = await self._wait(check, min(1.0, max(0.0, deadline - now)))
            now = loop.time()
            if outcome is not None or now >= deadline:
                return outcome
            if self.silent_s >= self.link_silent_s:
                return LINK_GONE
            clock = self._state.time_boot_s
            if clock is not None and clock != last_clock:
                last_clock, last_progress = clock, now
            elif now - last_progress >= timeout_s:
                return None

    async def _fly_wait(
        self,
        op: Operation,
        done: Callable[[TelemetryState], bool],
        timeout_s: float,
        *,
        flying: bool = True,
        modes: frozenset[str] = FLYING_MODES,
    ) -> tuple[CommandStatus, str | None, bool]:
        """Wait until ``done(state)``. (status, reason, reached): ``failed`` when superseded by a newer command or,
        for ``flying`` actions, when the vehicle disarms or switches to a mode not in ``modes``.

        ``timeout_s`` runs on the vehicle's own clock when it reports one (a simulator running slower than real
        time, say under a heavy camera load, has not failed to arrive), bounded by :data:`WALL_SLACK` times as
        much wall time; a vehicle whose clock stops for ``timeout_s`` of wall time has timed out."""
        start = self._state.time_boot_s

        def check(_msg: Any) -> Any:
            s = self._state
            if done(s):
                return "reached"
            if start is not None and s.time_boot_s is not None and s.time_boot_s - start > timeout_s:
                return OUT_OF_TIME
            if op.superseded_by is not None:
                return f"superseded by {op.superseded_by}"
            if flying:
                if s.mode != op.start_mode:
                    op.left_start_mode = True
                if op.left_start_mode and s.mode not in modes:
                    return f"interrupted: the vehicle switched to {s.mode}"
                if not s.armed and op.left_start_mode:
                    return "interrupted: the vehicle disarmed"
            return None

        outcome = await self._wait_on_vehicle_clock(check, timeout_s, start)
        if outcome == "reached":
            return "ok", None, True
        if outcome == OUT_OF_TIME:
            outcome = None
        if outcome == LINK_GONE:
            silent = self.silent_s
            heard = f"for {silent:.0f} s" if math.isfinite(silent) else "since the link closed"
            return "timeout", f"the link is gone: nothing heard from the vehicle {heard}", False
        texts = self.texts_since(op.text_mark)
        if outcome is None:
            why = f"not reached in {timeout_s:.0f} s"
            if not self.telemetry.connected:
                why += " (no telemetry from the vehicle)"
            return "timeout", why, False
        if isinstance(outcome, Exception):
            return "failed", f"internal error: {outcome}", False
        reason = str(outcome) + (f" ({texts[-1]})" if texts else "")
        return "failed", reason, False
