"""The shipped prompt templates and output schemas: present, complete, current with the contracts."""

from __future__ import annotations

import re
from pathlib import Path

import jsonschema
import pytest

import prompts
from agentic_core.cli import main
from agentic_core.reasoning import assessment, proposal

SCHEMA_SOURCES = {"assessment": assessment.schema_text, "plan": proposal.schema_text}
SCHEMA_DIR = Path(prompts.__file__).parent / "schemas"


@pytest.mark.parametrize("name", prompts.SCHEMAS)
def test_shipped_schemas_are_current(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    shipped = (SCHEMA_DIR / f"{name}.schema.json").read_text(encoding="utf-8")
    assert shipped == SCHEMA_SOURCES[name](), (
        f"prompts/schemas/{name}.schema.json is out of date; regenerate: agentic-uav schema {name} > "
        f"prompts/schemas/{name}.schema.json"
    )
    assert main(["schema", name]) == 0
    assert capsys.readouterr().out == shipped
    jsonschema.Draft202012Validator.check_schema(prompts.schema(name))


@pytest.mark.parametrize("name", prompts.TEMPLATES)
def test_every_template_renders_with_its_own_placeholders(name: str) -> None:
    text = prompts.template(name)
    names = set(re.findall(r"\$\{(\w+)\}", text))
    rendered = prompts.render(name, **{n: f"<{n}>" for n in names})
    literal = text.count("$${")  # a mission template written out for the model, ${event.id} say
    assert rendered.count("${") == literal and all(f"<{n}>" in rendered for n in names)


def test_a_missing_value_or_an_unknown_name_is_a_clear_error() -> None:
    with pytest.raises(prompts.PromptError, match=r"'assess' needs a value for \$\{world_model\}"):
        prompts.render("assess", goal="g", time_s=0, ego="e", focus_line="")
    with pytest.raises(prompts.PromptError, match="no prompt template 'asess'; there are: system, assess"):
        prompts.template("asess")
    with pytest.raises(prompts.PromptError, match="no output schema 'world'"):
        prompts.schema("world")


def test_values_with_braces_and_dollars_are_left_as_they_are() -> None:
    text = prompts.render(
        "assess", goal="$5 {x}", time_s=1, ego="e", focus_line="", world_model='{"a": "${b}"}', knowledge=""
    )
    assert '{"a": "${b}"}' in text and "$5 {x}" in text


def test_the_assessment_prompt_asks_for_a_self_reported_confidence() -> None:
    text = prompts.template("assess")
    assert "confidence" in text and "self-reported" in text


def test_the_schemas_accept_what_the_contracts_produce() -> None:
    a = assessment.Assessment(persons_detected=2, confidence=0.8, severity="low", recommended_actions=["log"])
    jsonschema.validate(a.model_dump(mode="json"), prompts.schema("assessment"))
    p = proposal.Proposal.model_validate({"steps": [{"id": "up", "action": "takeoff", "args": {"altitude_m": 20}}]})
    jsonschema.validate(p.model_dump(mode="json", by_alias=True, exclude_none=True), prompts.schema("plan"))
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"persons_detected": 1, "confidence": 1.5}, prompts.schema("assessment"))
