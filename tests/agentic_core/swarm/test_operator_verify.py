"""A casualty verified by the operator (``verify: {by: operator}``): the question goes to the finder's operator on
its control port, as an approval does — approved is verified (the alert may go), declined is not (no alert), and
no answer follows the mission's ``on_timeout`` — each answer traced in the UAV's run and in ``swarm.jsonl``; no other
UAV is sent to look. The older ``verify_k`` still reads, and is refused beside ``verify``."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from types import SimpleNamespace
from typing import Any

import pytest
from pydantic import ValidationError

from agentic_core.agent.bus import EventBus
from agentic_core.agent.control import ControlPort
from agentic_core.agent.pacing import Pace
from agentic_core.contracts.events import RunEvent
from agentic_core.contracts.swarm_plan import SwarmPlan, Verification
from agentic_core.run.swarm_operator import ask_on_port
from agentic_core.swarm.coordinator import SwarmCoordinator
from agentic_core.swarm.operator_verify import Verdict
from agentic_core.swarm.sectors import split
from agentic_core.swarm.signing import MemoryAudit, SwarmKey
from tests.agentic_core.swarm.test_coordinator import AREA, HOME, Uav, _world
from tests.waiting import wait_for

CORNERS = [{"lat": lat, "lon": lon} for lat, lon in AREA]


class Operator:
    """The finder's operator as the coordinator reaches it: a scripted verdict, and the questions it was asked."""

    def __init__(self, verdict: Verdict) -> None:
        self.verdict = verdict
        self.asked: list[tuple[dict[str, Any], float]] = []

    def __call__(self, request: dict[str, Any], timeout_s: float) -> Verdict:
        self.asked.append((request, timeout_s))
        return self.verdict


def _swarm(rule: Verification, operator: Operator | None) -> Iterator[tuple[SwarmCoordinator, list[dict[str, Any]]]]:
    uavs = [Uav("uav-1", -20.0), Uav("uav-2", 20.0)]
    uavs[0].sees = _world(("P-3", 100.0, -20.0))
    uavs[1].sees = _world(("P-9", 100.0, -19.0))  # the other UAV sees it too: k of n would verify it
    members = [u.member(30.0 + 10 * i) for i, u in enumerate(uavs)]
    members[0].ask = operator
    log: list[dict[str, Any]] = []
    swarm = SwarmCoordinator(SwarmKey.generate("mina"), members, split(AREA, 2, home=HOME), audit=MemoryAudit(),
                             log=log.append, verification=rule)  # fmt: skip
    try:
        swarm.allocate_sectors()
        swarm.claim("uav-1", "P-3")
        yield swarm, log
    finally:
        swarm.close()


@pytest.mark.parametrize(
    ("verdict", "on_timeout", "verified"),
    [("approved", "unverified", True), ("declined", "verified", False), ("no_answer", "unverified", False),
     ("no_answer", "verified", True)],
)  # fmt: skip
def test_the_operators_answer_decides_and_nobody_else_is_sent_to_look(
    verdict: Verdict, on_timeout: Any, verified: bool
) -> None:
    operator = Operator(verdict)
    rule = Verification(by="operator", timeout_s=42.0, on_timeout=on_timeout)
    for swarm, log in _swarm(rule, operator):
        rounds = len(swarm.manager.allocation.rounds)
        result = swarm.verify("uav-1", "C1", timeout_s=180.0, wait=lambda: None)
        assert result["verified"] is verified and result["answer"] == verdict and result["by"] == "operator"
        ((request, timeout_s),) = operator.asked
        assert timeout_s == 42.0 and request["args"]["casualty"] == "C1" and "uav-1" in request["question"]
        assert len(swarm.manager.allocation.rounds) == rounds  # no verify_casualty auctioned
        (record,) = [r for r in log if r["event"] == "verify"]
        assert (record["by"], record["answer"], record["verified"]) == ("operator", verdict, verified)
        assert swarm.casualties["C1"].verified is verified


def test_without_an_operator_to_ask_silence_is_the_rule() -> None:
    for swarm, _ in _swarm(Verification(by="operator"), None):
        assert swarm.verify("uav-1", "C1", timeout_s=1.0, wait=lambda: None)["answer"] == "no_answer"


def _run(approval: str) -> tuple[Any, list[RunEvent]]:
    events: list[RunEvent] = []
    bus = EventBus()
    bus.subscribe(events.append)
    run = SimpleNamespace(bus=bus, control=ControlPort(), pace=Pace(None), settings=SimpleNamespace(approval=approval))
    return run, events


REQUEST = {"step": "verify C1", "action": "verify_casualty", "question": "uav-1 reports C1: confirm?", "args": {}}


@pytest.mark.parametrize("answer", ["approve", "decline"])
def test_the_question_waits_on_the_uavs_control_port_like_an_approval(answer: str) -> None:
    run, events = _run("ask")
    box: list[Verdict] = []
    asking = threading.Thread(target=lambda: box.append(ask_on_port(run, REQUEST, 30.0)))
    asking.start()
    (question,) = wait_for(run.control.pending, 10.0, what="the question on the control port")
    assert question.request["question"] == REQUEST["question"]  # what the console and the terminal show
    getattr(run.control, answer)(question.id, by="console")
    asking.join(10.0)
    assert box == ["approved" if answer == "approve" else "declined"]
    asked, answered = [e.fields() for e in events if e.kind == "approval"]
    assert asked["status"] == "asked" and answered["via"] == "operator"
    assert answered["answer"] is (answer == "approve") and answered["verdict"] == box[0]


def test_no_answer_in_time_is_no_answer_not_a_decline() -> None:
    run, events = _run("ask")
    assert ask_on_port(run, REQUEST, 0.05) == "no_answer"
    assert [e.fields().get("verdict") for e in events if e.kind == "approval"] == [None, "no_answer"]


def test_a_headless_policy_answers_and_says_so() -> None:
    run, events = _run("decline")
    assert ask_on_port(run, REQUEST, 30.0) == "declined"
    assert [e.fields().get("via") for e in events if e.kind == "approval"] == [None, "policy"]


def test_verify_k_still_reads_and_is_refused_beside_verify() -> None:
    old = SwarmPlan.model_validate({"area": CORNERS, "verify_k": 3})
    assert (old.verify.by, old.verify.k) == ("uavs", 3)
    with pytest.raises(ValidationError, match="verify_k and verify"):
        SwarmPlan.model_validate({"area": CORNERS, "verify_k": 3, "verify": {"by": "operator"}})
    with pytest.raises(ValidationError, match="k does not go with by: operator"):
        SwarmPlan.model_validate({"area": CORNERS, "verify": {"by": "operator", "k": 2}})
    with pytest.raises(ValidationError, match="on_timeout does not go with by: uavs"):
        SwarmPlan.model_validate({"area": CORNERS, "verify": {"k": 2, "on_timeout": "verified"}})
