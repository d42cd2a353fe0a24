"""A casualty verified by the operator instead of other UAVs' eyes (a mission's ``verify: {by: operator}``): the
question goes to the finding UAV's operator — its control port, answered as an approval is, by the terminal, the
console or a script — and the answer decides: approved is verified, declined is not, and silence follows the
mission's ``on_timeout``. Every question and its verdict goes to ``swarm.jsonl`` (``verify``, ``by: operator``).

>>> from agentic_core.contracts.swarm_plan import Verification
>>> rule = Verification(by="operator", timeout_s=30, on_timeout="verified")
>>> verdict_of("approved", rule), verdict_of("declined", rule), verdict_of("no_answer", rule)
(True, False, True)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

from agentic_core.contracts.swarm_plan import Verification

Verdict = Literal["approved", "declined", "no_answer"]
Ask = Callable[[dict[str, Any], float], Verdict]
"""A UAV's operator: asked a question (an approval request) with a timeout in seconds, says what came of it."""


def verdict_of(answer: Verdict, rule: Verification) -> bool:
    """Whether the casualty counts as verified after the operator's ``answer`` under the mission's ``rule``."""
    if answer == "no_answer":
        return rule.on_timeout == "verified"
    return answer == "approved"


def question(casualty: Any, seen_by: list[str]) -> dict[str, Any]:
    """The approval request put to the operator about ``casualty`` (a coordinator's :class:`Casualty`)."""
    where = f"{casualty.lat:.6f}, {casualty.lon:.6f}"
    return {
        "step": f"verify {casualty.id}",
        "action": "verify_casualty",
        "question": f"{casualty.finder} reports a casualty ({casualty.id}) at {where}: confirm it before the alert?",
        "args": {"casualty": casualty.id, "found_by": casualty.finder, "object": casualty.object_id,
                 "lat": round(casualty.lat, 7), "lon": round(casualty.lon, 7), "seen_by": seen_by},
    }  # fmt: skip


def ask_operator(casualty: Any, ask: Ask | None, rule: Verification, seen_by: list[str]) -> tuple[Verdict, bool]:
    """Put the question to the finder's operator (``ask``; none: nobody to answer, as silence); the answer and
    whether the casualty is verified."""
    answer: Verdict = ask(question(casualty, seen_by), rule.timeout_s) if ask is not None else "no_answer"
    return answer, verdict_of(answer, rule)


__all__ = ["Ask", "Verdict", "ask_operator", "question", "verdict_of"]
