"""The ledger "critical event -> response" cannot be talked into calling an unanswered event answered: an alert
before the event, a refused or failed one, a replayed one, an alert that stayed in the outbox, none of them
makes a run with a critical casualty "completed"."""

from __future__ import annotations

from typing import Any

import pytest

from agentic_core.contracts import RunEvent
from agentic_core.run.responses import ResponseLedger


def event(kind: str, sim_t: float, **fields: Any) -> RunEvent:
    return RunEvent(kind=kind, seq=1, t=0.0, sim_t=sim_t, **fields)


def acted(ledger: ResponseLedger, focus: str = "P-12", at: float = 10.0, severity: str = "critical") -> None:
    ledger(event("trigger", at, trigger="collapsed", event=focus, act=True))
    ledger(event("decision", at + 1, focus=focus, assessment={"severity": severity}))


def alert(ledger: ResponseLedger, at: float, status: str = "ok", **fields: Any) -> None:
    ledger(event("tool", at, name="alerts.notify", status=status, **fields))


@pytest.mark.parametrize("outcome", ["completed", "returned", "aborted", "landed"])
def test_a_critical_event_with_no_alert_fails_whatever_the_flight_did(outcome: str) -> None:
    ledger = ResponseLedger()
    acted(ledger)
    assert ledger.outcome(outcome) == "failed"
    assert ledger.notes() == ["P-12 was judged critical at 11.0 s and no alert was sent: the event went without its "
                              "response."]  # fmt: skip


def test_alerts_that_do_not_answer_do_not_count() -> None:
    ledger = ResponseLedger()
    alert(ledger, 5.0, delivered_via="smtp")  # before the event: not its answer
    acted(ledger)
    alert(ledger, 20.0, status="denied", error="scope alerts:send missing")
    alert(ledger, 21.0, status="error", error="no recipients")  # failed outright: nothing kept
    alert(ledger, 22.0, delivered_via="smtp", replayed=True)  # a replay is not a new alert
    assert ledger.outcome("completed") == "failed"


def test_an_alert_kept_only_in_the_outbox_is_degraded_and_a_delivered_one_completes() -> None:
    ledger = ResponseLedger()
    acted(ledger)
    alert(ledger, 30.0, status="error", error="connection refused (a copy was kept in runs/x/alerts/a.eml)")
    assert ledger.outcome("completed") == "degraded" and ledger.outcome("returned") == "degraded"
    assert ledger.outcome("aborted") == "aborted"  # already not a success: degraded would read better than it is
    assert "reached only the outbox (connection refused" in ledger.notes()[0]
    alert(ledger, 31.0, delivered_via="smtp")
    assert ledger.outcome("completed") == "completed"
    assert ledger.notes() == ["P-12 was judged critical at 11.0 s; the alert went out at 31.0 s."]


def test_only_events_a_trigger_acted_on_and_judged_critical_need_an_answer() -> None:
    ledger = ResponseLedger()
    ledger(event("decision", 3.0, focus="P-1", assessment={"severity": "critical"}))  # seen on patrol, no trigger
    acted(ledger, "P-2", severity="high")  # looked at, not critical: a false alarm needs no alert
    ledger(event("trigger", 40.0, trigger="collapsed", event="P-3", act=False))
    ledger(event("decision", 41.0, focus="P-3", assessment={"severity": "critical"}))
    assert ledger.events() == {} and ledger.outcome("completed") == "completed"
    ledger(event("decision", 50.0, focus="P-2", assessment={"severity": "critical"}))  # confirmed on a closer look
    assert ledger.outcome("completed") == "failed"


def test_every_event_needs_its_own_answer_and_an_interrupted_run_is_left_to_resume() -> None:
    ledger = ResponseLedger()
    acted(ledger, "P-1", at=10.0)
    alert(ledger, 15.0, delivered_via="smtp")
    acted(ledger, "P-2", at=60.0)  # a second casualty after the only alert
    assert ledger.outcome("completed") == "failed"
    assert ledger.outcome("interrupted") == "interrupted"


def test_a_resumed_run_counts_what_happened_before_the_kill() -> None:
    before = ResponseLedger()
    acted(before)
    alert(before, 30.0, delivered_via="smtp")
    records: list[dict[str, Any]] = [
        {"kind": "trigger", "seq": 1, "t": 0.0, "sim_t": 10.0, "event": "P-12", "act": True},
        {"kind": "decision", "seq": 2, "t": 0.0, "sim_t": 11.0, "focus": "P-12",
         "assessment": {"severity": "critical"}},
        {"kind": "tool", "seq": 3, "t": 0.0, "sim_t": 30.0, "name": "alerts.notify", "status": "ok",
         "delivered_via": "smtp"},
        {"not": "an event"},
    ]  # fmt: skip
    resumed = ResponseLedger()
    resumed.replay(records)
    assert resumed.outcome("completed") == before.outcome("completed") == "completed"
    assert resumed.notes() == before.notes()


def critical_before_the_kill() -> list[dict[str, Any]]:
    return [
        {"kind": "trigger", "seq": 1, "t": 0.0, "sim_t": 10.0, "event": "P-12", "act": True},
        {
            "kind": "decision",
            "seq": 2,
            "t": 0.0,
            "sim_t": 11.0,
            "focus": "P-12",
            "assessment": {"severity": "critical"},
        },
    ]


@pytest.mark.parametrize(("via", "outcome"), [("outbox", "degraded"), ("smtp", "completed")])
def test_an_alert_sent_just_before_the_kill_answers_when_the_resumed_run_replays_it(via: str, outcome: str) -> None:
    """The kill came after the audit log kept the alert and before the trace did: the resumed run's replay of it
    is the only record that it was sent, and it answers the event."""
    resumed = ResponseLedger()
    resumed.replay(critical_before_the_kill())
    alert(resumed, 12.0, delivered_via=via, replayed=True, key="run:alert_medics:1.1")
    assert resumed.outcome("completed") == outcome
    assert "no alert was sent" not in resumed.notes()[0]


def test_an_alert_the_trace_kept_is_not_counted_again_when_it_is_replayed() -> None:
    records = [
        *critical_before_the_kill(),
        {
            "kind": "tool",
            "seq": 3,
            "t": 0.0,
            "sim_t": 12.0,
            "name": "alerts.notify",
            "status": "ok",
            "delivered_via": "smtp",
            "key": "run:alert_medics:1.1",
        },
    ]
    resumed = ResponseLedger()
    resumed.replay(records)
    alert(resumed, 20.0, delivered_via="smtp", replayed=True, key="run:alert_medics:1.1")
    alert(resumed, 21.0, delivered_via="smtp", replayed=True)  # a replay naming no key proves nothing
    assert len(resumed.alerts) == 1 and resumed.alerts[0].sim_t == 12.0
    assert resumed.outcome("completed") == "completed"
    refused = ResponseLedger()
    refused.replay(critical_before_the_kill())
    alert(refused, 12.0, status="denied", error="scope alerts:send missing", key="run:alert_medics:1.1")
    alert(refused, 13.0, status="denied", error="scope alerts:send missing", replayed=True, key="run:alert_medics:1.1")
    assert refused.outcome("completed") == "failed"  # a refusal, replayed, is still no alert
