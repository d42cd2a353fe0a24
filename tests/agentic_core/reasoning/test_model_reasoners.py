"""The llm and hybrid reasoners against the local stand-in server speaking OpenAI's wire format."""

from __future__ import annotations

import json
import time
from typing import Any

import pytest

from agentic_core.perception.world_model import WorldModel
from agentic_core.reasoning.llm import OpenAICompatibleClient
from agentic_core.reasoning.model_reasoners import HybridReasoner, LLMReasoner, world_model_prompt
from agentic_core.reasoning.reasoners import ReasonerError, make_reasoner
from agentic_core.reasoning.rules import RuleReasoner

from .llm.standin import StandIn, openai_completion, openai_error

EGO = {"north": 0, "east": 0, "down": -30, "lat": 21.4133, "lon": 39.8933, "alt": 30}
CRITICAL = {
    "persons_detected": 3,
    "confidence": 0.91,
    "surrounding_features": "An adult lying motionless on the ground, 30 m from the pedestrian flow, no shade nearby.",
    "severity": "critical",
    "recommended_actions": ["deploy_rescue_kit", "alert_medical_team"],
    "rationale": "Motionless and isolated: likely collapsed.",
    "subject_id": "P-9",
}


def person(pid: str, north: float, *, still: float = 0.0) -> dict[str, Any]:
    speed = 0.0 if still else 1.2
    return {
        "id": pid, "class": "person", "conf": 0.8, "stationary_s": still,
        "vel": {"north": speed, "speed": speed},
        "pose": {"north": north, "east": 0, "down": 0, "lat": 21.4133, "lon": 39.8933, "alt": 0},
    }  # fmt: skip


def world(emergency: bool, extra: int = 0) -> WorldModel:
    objects = [person("P-1", 0), person("P-2", 2), *(person(f"P-{100 + i}", -50 - i) for i in range(extra))]
    relations = []
    if emergency:
        objects.append(person("P-9", 40, still=15))
        relations.append({"subj": "P-9", "pred": "isolated_from", "obj": "crowd", "value": 38.0})
    return WorldModel.model_validate({"timestamp": 30, "ego_pose": EGO, "objects": objects, "relations": relations})


def test_the_model_assesses_from_the_world_model_and_its_answer_is_the_decision(
    standin: StandIn, client: OpenAICompatibleClient
) -> None:
    standin.script(openai_completion(json.dumps(CRITICAL), prompt_tokens=900, completion_tokens=80))
    decision = LLMReasoner(client, goal="Patrol Mina").assess(world(True))
    assert decision.ok and decision.reasoner == "llm:gpt-4o"
    assert decision.assessment is not None and decision.assessment.severity == "critical"
    assert (decision.llm_calls, decision.prompt_tokens, decision.completion_tokens) == (1, 900, 80)
    body = standin.bodies()[0]
    assert body["messages"][0]["role"] == "system" and "search-and-rescue" in body["messages"][0]["content"]
    prompt = body["messages"][1]["content"]
    assert "Patrol Mina" in prompt and '"P-9"' in prompt and '"isolated_from"' in prompt
    assert body["response_format"]["type"] == "json_schema"
    assert "self-reported" in prompt


def test_the_models_own_time_is_what_its_server_says(standin: StandIn, client: OpenAICompatibleClient) -> None:
    reply = openai_completion(json.dumps(CRITICAL))
    reply.headers["openai-processing-ms"] = "0.5"  # the server's own time; the rest of the wait is ours
    standin.script(reply)
    decision = LLMReasoner(client).assess(world(True))
    assert decision.ok and decision.model_time_s == pytest.approx(0.0005)
    assert decision.processing_time_s > decision.model_time_s


def test_a_failing_model_is_a_failed_decision(standin: StandIn, client: OpenAICompatibleClient) -> None:
    standin.script(openai_error(500, "overloaded"), openai_error(500, "overloaded"))
    decision = LLMReasoner(client).assess(world(True))
    assert not decision.ok and decision.error is not None and decision.error.startswith("http_error")


def test_output_breaking_the_schema_twice_is_a_failed_decision(
    standin: StandIn, client: OpenAICompatibleClient
) -> None:
    bad = json.dumps({**CRITICAL, "severity": "urgent"})
    standin.script(openai_completion(bad), openai_completion(bad))
    decision = LLMReasoner(client).assess(world(True))
    assert not decision.ok and "invalid_output" in (decision.error or "") and "severity" in (decision.error or "")
    assert len(standin.bodies()) == 2  # shown its mistake once


def test_hybrid_asks_the_model_only_on_critical_events_and_only_once_per_situation(
    standin: StandIn, client: OpenAICompatibleClient
) -> None:
    standin.script(openai_completion(json.dumps(CRITICAL)))
    hybrid = HybridReasoner(RuleReasoner(), LLMReasoner(client))
    calm = [hybrid.assess(world(False)) for _ in range(5)]
    assert all(d.ok and not d.escalated and d.llm_calls == 0 for d in calm)
    first = hybrid.assess(world(True))
    again = hybrid.assess(world(True))
    assert first.escalated and first.llm_calls == 1 and first.assessment == again.assessment
    assert again.cached and len(standin.bodies()) == 1 and again.llm_calls == 0 and again.prompt_tokens == 0
    assert (hybrid.consulted, hybrid.saved) == (1, 6)
    assert {d.reasoner for d in [*calm, first, again]} == {"hybrid"}


def test_hybrid_keeps_the_rules_reading_when_the_model_fails(standin: StandIn, client: OpenAICompatibleClient) -> None:
    standin.script(openai_error(503, "down"), openai_error(503, "down"))
    decision = HybridReasoner(RuleReasoner(), LLMReasoner(client)).assess(world(True))
    assert decision.ok and decision.assessment is not None and decision.assessment.severity == "critical"
    assert decision.error is not None and decision.error.startswith("model failed, rules' assessment kept")


def test_a_big_world_model_is_cut_to_the_most_telling_objects() -> None:
    text = world_model_prompt(world(True, extra=200), focus=None, max_objects=10)
    data = json.loads(text)
    ids = [o["id"] for o in data["objects"]]
    assert len(ids) == 10 and ids.count("P-9") == 1 and data["omitted_objects"] == 193
    assert len(json.loads(world_model_prompt(world(True), max_objects=10))["objects"]) == 3


def test_make_reasoner_names_what_is_wrong(standin: StandIn) -> None:
    with pytest.raises(ReasonerError, match="unknown reasoner 'gpt'; choose one of: yolo, rules, llm, hybrid"):
        make_reasoner("gpt")
    with pytest.raises(ReasonerError, match="needs a model"):
        make_reasoner("hybrid", environ={})
    with pytest.raises(ReasonerError, match="bogus"):
        make_reasoner("llm", llm="bogus:thing", environ={})
    made = make_reasoner("hybrid", llm=f"openai-compatible:qwen@{standin.url}/v1", environ={})
    assert made.name == "hybrid"


class _Slow:
    """A model reasoner that takes ``delay_s`` to answer (what a 40 s local model is to a 1 s deadline)."""

    name = "llm:slow"

    def __init__(self, inner: LLMReasoner, delay_s: float) -> None:
        self.inner, self.delay_s = inner, delay_s

    def assess(self, world: WorldModel, focus: str | None = None) -> Any:
        time.sleep(self.delay_s)  # the slowness under test
        return self.inner.assess(world, focus)


def test_hybrid_falls_back_to_its_rules_after_its_deadline(standin: StandIn, client: OpenAICompatibleClient) -> None:
    standin.script(openai_completion(json.dumps(CRITICAL)))
    hybrid = HybridReasoner(RuleReasoner(), _Slow(LLMReasoner(client), 3.0), deadline_s=0.5)  # type: ignore[arg-type]
    started = time.monotonic()
    decision = hybrid.assess(world(True))
    assert time.monotonic() - started < 2.5  # the rules answered; the model was not waited for
    assert decision.ok and decision.assessment is not None and decision.assessment.severity == "critical"
    assert decision.error == "model failed, rules' assessment kept: no answer within the 0.5 s deadline"
    assert decision.escalated and decision.llm_calls == 1


def test_a_deadline_must_be_positive() -> None:
    with pytest.raises(ValueError, match="deadline_s must be positive"):
        HybridReasoner(RuleReasoner(), LLMReasoner.__new__(LLMReasoner), deadline_s=0)
