"""Least privilege: the agent holds only the scopes its mission needs, a model's plan may call only the mission's
own tools (or its ``allow_tools``), and a model's output is capped before it reaches the trace, a prompt or a mail."""

from __future__ import annotations

import json
from pathlib import Path

from agentic_core.mission.compile import STEPS_ADAPTER
from agentic_core.mission.validate import load_mission
from agentic_core.reasoning.assessment import Assessment
from agentic_core.reasoning.llm.output_cap import CUT, MAX_OUTPUT_CHARS, max_output_chars
from agentic_core.reasoning.llm.structured import validate_output
from agentic_core.run.privilege import mission_caller, plan_tools, tool_problems
from tools import ToolRegistry
from tools.builtin import register_builtins
from tools.builtin.config import BuiltinConfig

REPO = Path(__file__).resolve().parents[3]
SURVEY_ONLY = """plan_id: look
goal: look around and come home
steps:
  - {id: up, action: takeoff}
  - {id: look, action: analyze_scene, depends_on: [up]}
  - {id: home, action: rtl, depends_on: [look]}
"""


def registry(tmp_path: Path) -> ToolRegistry:
    reg = ToolRegistry()
    register_builtins(reg, BuiltinConfig(outbox_dir=tmp_path))
    return reg


def test_a_mission_that_sends_no_alert_holds_no_scope_to_send_one(tmp_path: Path) -> None:
    agent = mission_caller(load_mission(SURVEY_ONLY), registry(tmp_path))
    assert agent.missing(["alerts:send", "incidents:write", "weather:read"]) == [
        "alerts:send",
        "incidents:write",
        "weather:read",
    ]
    emergency = mission_caller(load_mission(REPO / "missions" / "hajj_emergency.yaml"), registry(tmp_path))
    assert not emergency.missing(["alerts:send", "incidents:write"]) and emergency.missing(["weather:read"])


def test_declared_scopes_are_all_the_agent_holds(tmp_path: Path) -> None:
    plan = load_mission(SURVEY_ONLY.replace("steps:", "scopes: [flight:command, flight:read]\nsteps:"))
    assert mission_caller(plan, registry(tmp_path)).scopes == frozenset({"flight:command", "flight:read"})


def test_a_model_plan_calling_a_tool_the_mission_does_not_use_is_refused_unless_allowed() -> None:
    steps = STEPS_ADAPTER.validate_python(
        [
            {"id": "leak", "action": "call_tool", "tool": "alerts.webhook",
             "args": {"payload": {"lat": 21.4, "lon": 39.9}, "url": "https://collector.example/x"}},
            {"id": "mail", "action": "notify",
             "args": {"to": "someone@elsewhere.example", "subject": "s", "body": "b"}},
        ]
    )  # fmt: skip
    plan = load_mission(REPO / "missions" / "hajj_emergency.yaml")
    assert tool_problems(steps, plan_tools(plan)) == [
        "step 'leak': alerts.webhook is not a tool of this mission (its steps' tools and allow_tools)"
    ]
    allowed = plan.model_copy(update={"allow_tools": ["alerts.webhook"]})
    assert tool_problems(steps, plan_tools(allowed)) == []


def test_a_5_mb_assessment_is_capped_and_still_an_assessment() -> None:
    huge = {
        "persons_detected": 1, "confidence": 0.9, "severity": "critical", "subject_id": "P-12",
        "surrounding_features": "A" * 5_000_000, "recommended_actions": ["alert_medical_team"] * 100_000,
        "rationale": "R" * 1_000_000,
    }  # fmt: skip
    value, problem = validate_output(json.dumps(huge), Assessment)
    assert problem is None and isinstance(value, Assessment) and value.severity == "critical"
    assert len(value.model_dump_json()) < MAX_OUTPUT_CHARS + 4096
    assert value.surrounding_features.endswith(CUT)


def test_the_cap_is_configurable_and_a_bad_setting_keeps_the_default() -> None:
    assert max_output_chars({"AGENTIC_UAV_LLM_MAX_OUTPUT_CHARS": "1000"}) == 1000
    for bad in ("", "-5", "0", "lots"):
        assert max_output_chars({"AGENTIC_UAV_LLM_MAX_OUTPUT_CHARS": bad}) == MAX_OUTPUT_CHARS
