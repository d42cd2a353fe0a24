"""``agentic-uav schema NAME`` exports each contract's JSON Schema; ``--list`` names them; a wrong name exits 2."""

from __future__ import annotations

import json

import jsonschema
import pytest

from agentic_core.cli import SCHEMAS, main
from agentic_core.contracts import RunEvent, TelemetrySample
from agentic_core.contracts.assessment import Assessment, DecisionRecord
from agentic_core.contracts.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame
from agentic_core.contracts.tool_result import ToolResult

REQUIRED = (
    "world-model",
    "policy-graph",
    "detection",
    "frame",
    "assessment",
    "plan",
    "tool-result",
    "decision",
    "run-event",
    "telemetry",
)


def test_every_contract_the_issue_names_has_a_schema() -> None:
    assert set(REQUIRED) <= set(SCHEMAS)


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_each_schema_is_valid_json_schema(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema", name]) == 0
    schema = json.loads(capsys.readouterr().out)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert schema.get("properties")


def _schema(name: str, capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    assert main(["schema", name]) == 0
    loaded: dict[str, object] = json.loads(capsys.readouterr().out)
    return loaded


def test_the_schemas_accept_real_instances_and_refuse_broken_ones(capsys: pytest.CaptureFixture[str]) -> None:
    detection = Detection.model_validate(
        {"class": "person", "box": {"x_min": 0, "y_min": 0, "x_max": 4, "y_max": 8}, "confidence": 0.7}
    )
    frame = Frame(index=3, time_s=0.1, spec=CameraSpec(), pose=CameraPose(north_m=1, east_m=2, down_m=-30))
    assessment = Assessment(persons_detected=1, confidence=0.5, severity="low", surrounding_features="x")
    cases = {
        "detection": detection.model_dump(mode="json", by_alias=True),
        "frame": frame.model_dump(mode="json", by_alias=True),
        "assessment": assessment.model_dump(mode="json"),
        "decision": DecisionRecord(reasoner="rules", assessment=assessment, processing_time_s=0.01).model_dump(
            mode="json"
        ),
        "tool-result": ToolResult(status="ok", latency_s=0.0, attempts=1, call_id="c", tool="t").model_dump(
            mode="json"
        ),
        "run-event": RunEvent(kind="tool", seq=1, name="x").model_dump(mode="json"),
        "telemetry": TelemetrySample(
            time_s=0, lat_deg=1, lon_deg=2, alt_m=3, north_m=0, east_m=0, down_m=-3
        ).model_dump(mode="json"),
    }
    for name, instance in cases.items():
        schema = _schema(name, capsys)
        validator = jsonschema.Draft202012Validator(schema)
        validator.validate(instance)
        broken = dict(instance)
        required = schema["required"]
        assert isinstance(required, list) and required, name
        broken.pop(required[0])
        assert not validator.is_valid(broken), name
    assert "image" not in json.dumps(_schema("frame", capsys)["properties"])
    assert BoundingBox(x_min=0, y_min=0, x_max=1, y_max=1).width == 1


def test_list_names_every_schema(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema", "--list"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == list(SCHEMAS)


@pytest.mark.parametrize("argv", [["schema", "no-such-contract"], ["schema"], ["schema", ""]])
def test_an_unknown_or_missing_name_exits_2_with_the_list(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "agentic-uav schema: error:" in captured.err
    assert all(name in captured.err for name in SCHEMAS)
    assert "Traceback" not in captured.err


def test_the_shipped_schema_files_match_the_models(capsys: pytest.CaptureFixture[str]) -> None:
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    shipped = {
        "policy-graph": root / "missions" / "mission.schema.json",
        "world-model": root / "agentic_core" / "perception" / "world_model.schema.json",
        "assessment": root / "prompts" / "schemas" / "assessment.schema.json",
        "plan": root / "prompts" / "schemas" / "plan.schema.json",
        "scene": root / "scenes" / "scene.schema.json",
    }
    for name, path in shipped.items():
        assert json.loads(path.read_text()) == _schema(name, capsys), path
