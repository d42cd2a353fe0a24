"""What the runner checks of steps a model proposes, beyond the mission validator: the agent may call every tool
they use (its scopes), and the actions that put people at risk ask the operator first.

The validator already refuses unknown actions and tools, bad arguments and flights outside the envelope; the
executor would also refuse a missing scope when the step runs, but by then the plan is half flown. Checking here
refuses the whole plan before any of it runs, with every reason at once.

>>> from tools import Caller, ToolRegistry
>>> from agentic_core.mission.compile import STEPS_ADAPTER
>>> steps = STEPS_ADAPTER.validate_python([{"id": "drop", "action": "deploy_payload", "args": {"payload": "kit"}}])
>>> review(steps, ToolRegistry(), Caller(id="agent"))
["step 'drop': deploy_payload must ask the operator first (approval: true)"]
"""

from __future__ import annotations

from tools import Caller, ToolRegistry

from ..mission.model import ACTION_TOOLS, Step
from ..mission.validate import walk_steps

NEEDS_APPROVAL = frozenset({"land", "deploy_payload"})
"""Actions a model's plan may take only with an operator's yes: landing near people, releasing a payload."""


def review(steps: list[Step], registry: ToolRegistry, caller: Caller) -> list[str]:
    """The reasons to refuse ``steps`` (empty: none): tools ``caller`` may not call, risky actions unapproved."""
    problems: list[str] = []
    for site in walk_steps(steps):
        step = site.step
        tool = getattr(step, "tool", None) if step.action == "call_tool" else ACTION_TOOLS.get(step.action)
        if tool is not None and tool in registry:
            missing = caller.missing(registry.get(tool).scopes)
            if missing:
                problems.append(f"step {step.id!r}: {tool} needs scope {', '.join(missing)}, which the agent lacks")
        if step.action in NEEDS_APPROVAL and not step.approval:
            problems.append(f"step {step.id!r}: {step.action} must ask the operator first (approval: true)")
    return problems


__all__ = ["NEEDS_APPROVAL", "review"]
