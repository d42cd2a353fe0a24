"""The runner's review of steps a model proposes: scopes the agent lacks and risky actions without approval."""

from __future__ import annotations

from agentic_core.mission.compile import STEPS_ADAPTER
from agentic_core.run.plan_review import review
from agentic_core.run.runner import AGENT
from tools import Caller, ToolRegistry, ToolSpec


def registry() -> ToolRegistry:
    reg = ToolRegistry()
    reg.register(ToolSpec.from_schema("vault.open", lambda args: "open", {"type": "object"}, scopes=["vault:admin"]))
    reg.register(ToolSpec.from_schema("incidents.log", lambda args: 1, {"type": "object"}, scopes=["incidents:write"]))
    return reg


def test_a_tool_beyond_the_agents_scopes_is_refused_nested_steps_included() -> None:
    steps = STEPS_ADAPTER.validate_python(
        [
            {"id": "note", "action": "call_tool", "tool": "incidents.log"},
            {"id": "loop", "action": "repeat", "until": "true", "steps": [
                {"id": "open", "action": "call_tool", "tool": "vault.open"}
            ]},
        ]
    )  # fmt: skip
    refused = ["step 'open': vault.open needs scope vault:admin, which the agent lacks"]
    assert review(steps, registry(), AGENT) == refused
    assert review(steps, registry(), Caller(id="root", scopes=frozenset({"*"}))) == []


def test_landing_and_payload_release_need_the_operators_yes() -> None:
    steps = STEPS_ADAPTER.validate_python(
        [
            {"id": "down", "action": "land", "args": {"target_id": "P-1"}},
            {"id": "drop", "action": "deploy_payload", "args": {"payload": "kit"}, "approval": True},
            {"id": "home", "action": "rtl"},
        ]
    )
    assert review(steps, registry(), AGENT) == ["step 'down': land must ask the operator first (approval: true)"]
