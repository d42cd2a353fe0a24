"""The model's response plan (the stand-in speaking OpenAI's format): what the planning prompt carries, what
comes back, and a model that fails or proposes nothing."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest

from agentic_core.mission import load_mission
from agentic_core.reasoning.assessment import Assessment
from agentic_core.reasoning.llm import OpenAICompatibleClient, RetryPolicy
from agentic_core.reasoning.planning import LLMPlanner, Tool, actions_text

from .llm.standin import StandIn, openai_completion, openai_error

PLAN = load_mission(
    """
plan_id: p
goal: help whoever collapses
limits: {geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 500}, max_altitude_m: 60}
steps: [{id: up, action: takeoff}]
""",
    file="m.yaml",
)
TOOLS = [
    Tool(
        "incidents.log", "Log an incident.\nMore text.", {"properties": {"kind": {}, "note": {}}, "required": ["kind"]}
    ),
    Tool("flight.fly_to", "Fly to a point.", {"properties": {"lat": {}}}),
]
ASSESSMENT = Assessment(persons_detected=1, confidence=0.8, severity="critical", subject_id="P-4", rationale="still")
EVENT = {"id": "P-4", "class": "person", "pose": {"lat": 21.414, "lon": 39.894}, "stationary_s": 12.0}


@pytest.fixture
def standin() -> Iterator[StandIn]:
    with StandIn() as server:
        yield server


def planner(server: StandIn, log: list[dict[str, Any]]) -> LLMPlanner:
    async def no_wait(seconds: float) -> None:
        return None

    client = OpenAICompatibleClient(
        "gpt-4o", server.url + "/v1", api_key="sk-x", trust_env=False, sleep=no_wait, retry=RetryPolicy(attempts=1)
    )
    return LLMPlanner(client, PLAN, TOOLS, record=log.append)


def test_the_actions_text_lists_the_actions_and_the_tools_no_action_stands_for() -> None:
    text = actions_text(TOOLS)
    assert "fly_to" in text and "call_tool" in text and "- incidents.log(kind, note?): Log an incident." in text
    assert "flight.fly_to(" not in text  # the fly_to action stands for it


def test_the_prompt_carries_the_assessment_the_event_the_limits_and_the_tools(standin: StandIn) -> None:
    steps = [{"id": "go", "action": "fly_to", "args": {"target_id": "${event.id}", "alt_m": 15}}]
    standin.script(openai_completion(json.dumps({"steps": steps, "rationale": "go and see"})))
    log: list[dict[str, Any]] = []
    proposed = planner(standin, log)(ASSESSMENT, EVENT)
    assert proposed is not None and [(s["id"], s["action"], s["args"]["target_id"]) for s in proposed] == [
        ("go", "fly_to", "${event.id}")
    ]
    body = standin.bodies()[0]
    prompt = body["messages"][1]["content"]
    assert '"severity":"critical"' in prompt and '"stationary_s": 12.0' in prompt and '"radius_m": 500' in prompt
    assert "help whoever collapses" in prompt and "incidents.log(kind, note?)" in prompt
    assert body["response_format"]["json_schema"]["name"] == "Proposal"
    assert log[0]["event"] == "P-4" and log[0]["outcome"] == "1 step(s) proposed" and log[0]["rationale"]


@pytest.mark.parametrize("reply", ["nothing", "error"])
def test_nothing_proposed_or_a_failing_model_gives_none_and_is_recorded(standin: StandIn, reply: str) -> None:
    if reply == "nothing":
        standin.script(openai_completion(json.dumps({"steps": [], "rationale": "no action needed"})))
    else:
        standin.script(openai_error(500, "overloaded"))
    log: list[dict[str, Any]] = []
    assert planner(standin, log)(None, EVENT) is None
    assert (
        log[0]["outcome"] == "nothing proposed" if reply == "nothing" else log[0]["outcome"].startswith("no proposal")
    )
    if reply == "nothing":
        assert "none (the reasoner failed)" in standin.bodies()[0]["messages"][1]["content"]
