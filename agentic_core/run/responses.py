"""Honest outcomes: did every critical event get its response? Fed by the run's bus events, it keeps the ledger
"critical event -> response" and says what the run's outcome must be.

A *critical event* is an object a trigger acted on (the gate let it) that the reasoner judged ``critical``, at the
gate or at a later look. Its *response* is an alert (``alerts.notify``, ``alerts.send_email``, ``alerts.webhook``)
sent after it. An event with no alert at all makes the run ``failed`` (exit 1), however the flight ended; alerts
that reached only the outbox (no mail server, or it could not be reached) make a run that would have completed
``degraded`` (:data:`DEGRADED_EXIT`). :meth:`ResponseLedger.notes` says why, in words, for ``report.md``.

>>> from agentic_core.contracts import RunEvent
>>> ledger = ResponseLedger()
>>> ledger(RunEvent(kind="trigger", seq=1, t=0.0, sim_t=40.0, trigger="collapsed_person", event="P-12", act=True))
>>> ledger(RunEvent(kind="decision", seq=2, t=0.0, sim_t=41.5, focus="P-12", assessment={"severity": "critical"}))
>>> ledger.outcome("completed")
'failed'
>>> ledger(RunEvent(kind="tool", seq=3, t=0.0, sim_t=60.0, name="alerts.notify", status="ok", delivered_via="outbox"))
>>> ledger.outcome("completed"), ledger.notes()[0]
('degraded', 'P-12 was judged critical at 41.5 s; the alert at 60.0 s reached only the outbox: nobody was told.')
"""

from __future__ import annotations

import contextlib
import threading
from dataclasses import dataclass, field
from typing import Any

from pydantic import ValidationError

from ..contracts import RunEvent

ALERT_TOOLS = frozenset({"alerts.notify", "alerts.send_email", "alerts.webhook"})
"""The tools whose call is a response to a critical event."""

DEGRADED_EXIT = 3
"""``agentic-uav run``'s exit status for a ``degraded`` run: every critical event got an alert, but some reached
only the outbox (0 completed or returned, 1 failed or aborted, 2 bad input)."""

KEEPS = ("interrupted",)
"""Outcomes the ledger leaves alone: a run stopped by a signal goes on with ``--resume``, its response may follow."""


@dataclass
class _Alert:
    sim_t: float
    delivered: bool
    why: str


@dataclass
class ResponseLedger:
    """Critical events and the alerts that answered them, from bus events (a subscriber: ``bus.subscribe``)."""

    critical: dict[str, float] = field(default_factory=dict)  # object -> when it was first judged critical
    acted_on: set[str] = field(default_factory=set)
    alerts: list[_Alert] = field(default_factory=list)
    keys: set[str] = field(default_factory=set)  # idempotency keys of the alerts counted
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __call__(self, event: RunEvent) -> None:
        fields = event.fields()
        sim_t = event.sim_t if event.sim_t is not None else 0.0
        with self._lock:
            if event.kind == "trigger" and fields.get("act") and isinstance(fields.get("event"), str):
                self.acted_on.add(fields["event"])
            elif event.kind == "decision":
                assessment = fields.get("assessment") or {}
                focus = fields.get("focus") or assessment.get("subject_id")
                if isinstance(focus, str) and assessment.get("severity") == "critical":
                    self.critical.setdefault(focus, sim_t)
            elif event.kind == "tool" and fields.get("name") in ALERT_TOOLS:
                self._alert(fields, sim_t)

    def replay(self, records: list[dict[str, Any]]) -> None:
        """Count a resumed run's earlier trace records, as if they had come by the bus."""
        for record in records:
            with contextlib.suppress(ValidationError):
                self(RunEvent.model_validate(record))

    def _alert(self, fields: dict[str, object], sim_t: float) -> None:
        # A replayed alert was sent before a kill; it counts once, unless the trace already counted it (the kill may
        # have come after the audit log kept it and before the trace did).
        key = fields.get("key")
        if key in self.keys or (fields.get("replayed") and not isinstance(key, str)):
            return
        status, via, error = fields.get("status"), fields.get("delivered_via"), str(fields.get("error") or "")
        if status == "ok":
            delivered = via not in ("outbox", None)
            why = "" if delivered else "reached only the outbox: nobody was told"
        elif "copy was kept" in error:
            delivered, why = False, f"reached only the outbox ({error})"
        else:
            return  # refused or failed outright: no alert, not a response
        if isinstance(key, str):
            self.keys.add(key)
        self.alerts.append(_Alert(sim_t, delivered, why))

    def events(self) -> dict[str, float]:
        """The critical events: objects a trigger acted on, judged critical (object -> when first judged so)."""
        with self._lock:
            return {k: t for k, t in self.critical.items() if k in self.acted_on}

    def _answers(self, since: float) -> list[_Alert]:
        return [a for a in self.alerts if a.sim_t >= since]

    def outcome(self, outcome: str) -> str:
        """The run's outcome once the ledger is counted: ``failed`` when a critical event got no alert,
        ``degraded`` when a run that would have completed alerted only the outbox; else ``outcome`` as it was."""
        if outcome in KEEPS:
            return outcome
        answers = [self._answers(t) for t in self.events().values()]
        if any(not a for a in answers):
            return "failed"
        if outcome in ("completed", "returned") and any(not any(x.delivered for x in a) for a in answers):
            return "degraded"
        return outcome

    def notes(self) -> list[str]:
        """One plain sentence per critical event: its response, or why it had none."""
        out = []
        for focus, t in sorted(self.events().items(), key=lambda kv: kv[1]):
            answers = self._answers(t)
            judged = f"{focus} was judged critical at {t:.1f} s"
            if not answers:
                out.append(f"{judged} and no alert was sent: the event went without its response.")
            elif any(a.delivered for a in answers):
                first = next(a for a in answers if a.delivered)
                out.append(f"{judged}; the alert went out at {first.sim_t:.1f} s.")
            else:
                out.append(f"{judged}; the alert at {answers[0].sim_t:.1f} s {answers[0].why}.")
        return out


__all__ = ["ALERT_TOOLS", "DEGRADED_EXIT", "KEEPS", "ResponseLedger"]
