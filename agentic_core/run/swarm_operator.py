"""A swarm UAV's operator, for a mission whose casualties the operator verifies (``verify: {by: operator}``): the
question is asked on the UAV's own control port — the approval path, so the terminal, the console or a test's
operator script answers it — or answered by the run's headless policy (``--approval approve|decline``), and traced
in the UAV's run as an ``approval`` event either way.

Every UAV of a swarm run asks its questions (approvals, verifications) at one terminal, :class:`SharedTerminal`:
one reader of the input, one question at a time, each naming its UAV, so two UAVs never prompt at once and an
answer goes to the question it was typed under.

>>> import io
>>> terminal = SharedTerminal(io.StringIO("y\\nn\\n"), io.StringIO(), timeout_s=1.0)
>>> ask_2, ask_3 = terminal.for_uav("uav-2"), terminal.for_uav("uav-3")
>>> ask_2({"step": "land_near", "question": "approve land?"}).approved, ask_3({"step": "land_near"}).approved
(True, False)
>>> [line.split("[y/N]")[0].strip() for line in terminal.out.getvalue().splitlines() if line]
['>>> operator: uav-2: approve land?', '>>> operator: uav-3: approve land_near?']
"""

from __future__ import annotations

import threading
from typing import Any, TextIO

from ..agent.control import Operator, OperatorAnswer
from ..swarm.operator_verify import Verdict
from .operator import TerminalOperator


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


class SharedTerminal:
    """One terminal for every UAV's operator in a swarm run: questions asked one at a time, each naming its UAV."""

    def __init__(self, answers: TextIO, out: TextIO, *, timeout_s: float = 120.0) -> None:
        self.out = out
        self._terminal = TerminalOperator(answers, out, timeout_s=timeout_s)
        self._turn = threading.Lock()

    def for_uav(self, uav: str) -> Operator:
        """``uav``'s operator: its questions wait their turn at the terminal (the ``timeout_s`` counts from the
        prompt), prefixed with its name."""

        def ask(request: dict[str, Any]) -> OperatorAnswer:
            question = request.get("question") or f"approve {request.get('step')}?"
            with self._turn:
                return self._terminal({**request, "question": f"{uav}: {question}"})

        return ask


__all__ = ["SharedTerminal", "ask_on_port"]
