"""A swarm UAV's operator, for a mission whose casualties the operator verifies (``verify: {by: operator}``): the
question is asked on the UAV's own control port — the approval path, so the terminal, the console or a test's
operator script answers it — or answered by the run's headless policy (``--approval approve|decline``), and traced
in the UAV's run as an ``approval`` event either way.
"""

from __future__ import annotations

from typing import Any

from ..swarm.operator_verify import Verdict


def ask_on_port(run: Any, request: dict[str, Any], timeout_s: float) -> Verdict:
    """Ask ``request`` of ``run``'s operator (a :class:`~agentic_core.run.runner.MissionRun`), waiting at most
    ``timeout_s`` wall seconds (the simulation at real time meanwhile); what came of it."""
    run.bus.publish("approval", request=request, status="asked", summary=f"asked: {request['question']}")
    if run.settings.approval != "ask":
        approve = run.settings.approval == "approve"
        policy: Verdict = "approved" if approve else "declined"
        run.bus.publish("approval", request=request, answer=approve, via="policy",
                        summary=f"{request['step']}: {policy} (headless policy)")  # fmt: skip
        return policy
    with run.pace.waiting("operator"):
        answer = run.control.ask(request, timeout_s)
    verdict: Verdict = "no_answer" if answer.timed_out else "approved" if answer.approved else "declined"
    run.bus.publish("approval", request=request, answer=answer.approved, via="operator", said=answer.said,
                    verdict=verdict, summary=f"{request['step']}: {answer.why}")  # fmt: skip
    return verdict


__all__ = ["ask_on_port"]
