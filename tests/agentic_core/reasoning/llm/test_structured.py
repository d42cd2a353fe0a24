"""Structured output: valid at once, broken then fixed after the model is shown the problem, broken twice; each
asked both ways, ``await chat_structured()`` and ``chat_structured_sync()``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal

from pydantic import BaseModel, Field

from agentic_core.reasoning.llm import ChatRequest, Message, OllamaClient, OpenAICompatibleClient

from .conftest import Ask
from .standin import StandIn, ollama_chat, openai_completion, openai_error

MakeClient = Callable[..., OpenAICompatibleClient]


class Assessment(BaseModel):
    """What the reasoner says of a scene."""

    persons_detected: int = Field(ge=0)
    confidence: float = Field(ge=0, le=1)
    severity: Literal["none", "low", "high", "critical"]


REQUEST = ChatRequest(messages=[Message.system("Assess the scene."), Message.user("Two persons by a tent.")])
VALID = '{"persons_detected": 2, "confidence": 0.8, "severity": "high"}'


def test_a_valid_reply(standin: StandIn, openai_client: MakeClient, ask: Ask) -> None:
    standin.script(openai_completion(VALID))
    result = ask(openai_client(), REQUEST, Assessment)

    assert result.ok and not result.repaired
    assert result.parsed == Assessment(persons_detected=2, confidence=0.8, severity="high")
    response_format = standin.received[0].body["response_format"]
    assert response_format["type"] == "json_schema"
    assert response_format["json_schema"]["name"] == "Assessment"
    assert response_format["json_schema"]["schema"] == Assessment.model_json_schema()
    assert response_format["json_schema"]["strict"] is False


def test_invalid_then_fixed(standin: StandIn, openai_client: MakeClient, ask: Ask) -> None:
    standin.script(
        openai_completion('{"persons_detected": 2, "confidence": 1.7, "severity": "high"}', prompt_tokens=50),
        openai_completion(VALID, prompt_tokens=80),
    )
    client = openai_client()
    result = ask(client, REQUEST, Assessment)

    assert result.ok and result.repaired and isinstance(result.parsed, Assessment)
    assert result.attempts == 2 and result.usage.prompt_tokens == 130
    retry = standin.received[1].body["messages"]
    assert retry[2] == {
        "role": "assistant",
        "content": '{"persons_detected": 2, "confidence": 1.7, "severity": "high"}',
    }
    assert retry[3]["role"] == "user" and "confidence: Input should be less than or equal to 1" in retry[3]["content"]
    assert client.totals.calls == 2  # the client counts each request it made


def test_not_json_then_fixed(standin: StandIn, openai_client: MakeClient, ask: Ask) -> None:
    standin.script(openai_completion("Two persons, high severity."), openai_completion(VALID))
    result = ask(openai_client(), REQUEST, Assessment)
    assert result.ok and result.repaired
    assert "the reply is not JSON" in standin.received[1].body["messages"][3]["content"]


def test_invalid_twice(standin: StandIn, openai_client: MakeClient, ask: Ask) -> None:
    standin.script(openai_completion('{"severity": "bad"}'), openai_completion('{"severity": "worse"}'))
    result = ask(openai_client(), REQUEST, Assessment)

    assert result.status == "invalid_output" and result.parsed is None
    assert result.content == '{"severity": "worse"}' and result.attempts == 2
    assert result.error is not None
    assert result.error.startswith("the reply does not match the schema 'Assessment' after 1 correction: ")
    assert "persons_detected: Field required" in result.error


def test_a_json_schema_dict_and_a_fenced_reply(
    standin: StandIn, ollama_client: Callable[..., OllamaClient], ask: Ask
) -> None:
    schema = {"type": "object", "properties": {"land": {"type": "boolean"}}, "required": ["land"]}
    standin.script(ollama_chat('```json\n{"land": true}\n```'))
    result = ask(ollama_client(), REQUEST, schema, name="decision")
    assert result.ok and result.parsed == {"land": True}
    assert standin.received[0].body["format"] == schema


def test_a_failed_call_is_returned_as_it_is(standin: StandIn, openai_client: MakeClient, ask: Ask) -> None:
    standin.script(openai_error(401, "Invalid Authentication", code="invalid_api_key"))
    result = ask(openai_client(), REQUEST, Assessment)
    assert result.status == "http_error" and result.attempts == 1


def test_a_failure_in_the_correction_round_keeps_both_counts(
    standin: StandIn, openai_client: MakeClient, ask: Ask
) -> None:
    standin.script(openai_completion("nope", prompt_tokens=9), openai_error(400, "context too long"))
    result = ask(openai_client(), REQUEST, Assessment)
    assert result.status == "http_error" and result.attempts == 2 and result.usage.prompt_tokens == 9


def test_a_refusal_is_not_corrected(standin: StandIn, openai_client: MakeClient, ask: Ask) -> None:
    standin.script(openai_completion(None, refusal="I won't assess this."))
    result = ask(openai_client(), REQUEST, Assessment)
    assert result.status == "refusal" and len(standin.received) == 1
