"""``agentic-uav run`` end to end: the simulated vehicle over MAVLink, perception over a scene, the tools, the
reasoner, the trace and the report. The scenes are the paper's two with thin crowds, so a run takes seconds; the
camera runs at 15 Hz, half its default, in the rules and operator runs, and at 5 Hz where what is tested is the
model's part or the patrol (perception at 30 Hz is tested on its own, in tests/agentic_core/perception)."""

from __future__ import annotations

import contextlib
import email
import json
import math
import os
import re
from email.message import Message
from pathlib import Path
from typing import Any

import pytest

from agentic_core.cli import main
from agentic_core.contracts.geodesy import local_offset
from agentic_core.run.operator import OperatorAnswer
from agentic_core.run.runner import MissionRun, RunResult, RunSettings, run_mission
from flight.signing import read_key_file
from flight.sim.scene_file import load_scene
from tools import ToolSpec

from ..reasoning.llm.standin import StandIn
from .scripted_model import EMERGENCY_PLAN, ScriptedModel

REPO = Path(__file__).resolve().parents[3]
SCENES = Path(__file__).parent / "scenes"
EMERGENCY = REPO / "missions" / "hajj_emergency.yaml"
PATROL = REPO / "missions" / "hajj_patrol.yaml"


def fly(tmp_path: Path, mission: Path, scene: str, **options: Any) -> RunResult:
    settings = RunSettings(
        mission=mission, scene=SCENES / f"{scene}.yaml", runs_dir=tmp_path / "runs", params={"rounds": "1"}, **options
    )
    return run_mission(settings, progress=None)


def fly_with_model(tmp_path: Path, scene: str, model: ScriptedModel, camera_hz: float = 5.0) -> tuple[RunResult, int]:
    """The emergency mission with ``--reasoner llm`` against ``model`` behind the stand-in; the run and how many
    chat requests the stand-in answered."""
    with StandIn(responder=model) as server:
        llm = f"openai-compatible:m@{server.url}/v1"
        result = fly(tmp_path, EMERGENCY, scene, reasoner="llm", llm=llm, camera_hz=camera_hz)
        return result, len(server.bodies())


def records(result: RunResult, kind: str) -> list[dict[str, Any]]:
    lines = (result.run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()
    return [r for r in map(json.loads, lines) if r["kind"] == kind]


def tools_called(result: RunResult) -> list[str]:
    return [r["name"] for r in records(result, "tool") if r.get("status") != "interrupted"]


@pytest.mark.slow
def test_the_emergency_is_found_confirmed_and_answered_with_the_rules_reasoner(tmp_path: Path, smtp: Any) -> None:
    result = fly(tmp_path, EMERGENCY, "small_emergency", camera_hz=15.0)
    summary = result.summary
    assert summary.outcome in ("completed", "returned"), summary
    tools = tools_called(result)
    # the patrol leg was stopped for the person, who was then approached, watched, confirmed and helped
    assert [r for r in records(result, "trigger") if r["act"]], "the trigger never acted"
    for earlier, later in [("alerts.notify", "flight.land"), ("flight.land", "flight.deploy_payload")]:
        assert tools.index(earlier) < tools.index(later), tools
    assert tools[-1] == "flight.rtl" and "incidents.log" not in tools
    verdicts = [r["assessment"]["severity"] for r in records(result, "decision") if r["why"] == "analyze_scene"]
    assert "critical" in verdicts
    assert [(r["request"]["step"], r["answer"]) for r in records(result, "approval") if "answer" in r] == [
        ("land_near", True), ("release_kit", True)
    ]  # fmt: skip

    # it landed beside P-12 (5 m short, on the side it came from), not on them and not elsewhere
    scene = load_scene(SCENES / "small_emergency.yaml")
    casualty = scene.actor("P-12").position
    touch = [p for p in _track(result) if p["alt_m"] < 0.5 and p["sim_t"] > 20]
    assert touch, "never touched down away from home"
    gap = math.hypot(touch[0]["north_m"] - casualty.north, touch[0]["east_m"] - casualty.east)
    assert 2.0 < gap < 9.0, gap

    # the alert went out by SMTP, with the GPS position, the assessment and the annotated image attached
    (envelope,) = smtp.inbox.envelopes
    message = email.message_from_bytes(envelope.content)
    subject = message["Subject"]
    assert message["To"] == "medical-team@example.org" and subject.startswith("Collapsed pilgrim P-")
    coordinates = subject.split(" at ", 1)[1].split(", ")
    assert all(len(x.split(".")[1]) <= 6 for x in coordinates), subject  # 1e-6 degrees, not 16 digits
    lat, lon = (float(x) for x in coordinates)
    north, east = local_offset(scene.home.lat_deg, scene.home.lon_deg, lat, lon)
    assert math.hypot(north - casualty.north, east - casualty.east) < 3.0  # the tracked position, within metres
    names = sorted(str(part.get_filename()) for part in _attachments(message))
    assert [n.split("-", 1)[1] for n in names] == [
        "assessment.json", "position.json", "snapshot.png", "world_model.json"
    ]  # fmt: skip
    body = _text(message)
    assert "isolated from pedestrian flow" in body

    # the run's folder holds what the issue names
    folder = result.run_dir
    assert (folder / "report.md").is_file() and (folder / "trajectory.png").read_bytes()[:4] == b"\x89PNG"
    worlds = (folder / "world_models.jsonl").read_text(encoding="utf-8").splitlines()
    assert len(worlds) == summary.decisions and json.loads(worlds[-1])["objects"]
    report = (folder / "report.md").read_text(encoding="utf-8")
    # one id for the casualty: the tracker's, in the decisions, the alert and the report, linked to the scene's
    tracked = subject.split()[2]
    assert f"Casualty {tracked} (scene P-12): first detected at" in report and "alert sent at" in report
    assert f"on {tracked} (scene P-12): severity **critical**" in report
    assert any(r.get("object") == tracked and r.get("truth") == "P-12" for r in records(result, "log"))
    assert not re.search(r"\d\.\d{7,}", report), "a raw float in the report"
    position = json.loads(next(p for p in folder.glob("alerts/*position.json")).read_text(encoding="utf-8"))
    assert position["subject"]["id"] == tracked and len(str(position["subject"]["lat"]).split(".")[1]) <= 6
    key_file = folder / "signing.key"  # the in-process vehicle took only what its client signed with this
    assert key_file.stat().st_mode & 0o777 == 0o600 and len(read_key_file(key_file)) == 32


@pytest.mark.slow
def test_the_normal_scene_brings_no_intervention_from_the_model(tmp_path: Path) -> None:
    """The emergency mission over normal activity with the llm reasoner: the model reads each scan's World Model
    and sees no one in distress (people resting in the shade are not casualties), so nothing is planned."""
    model = ScriptedModel()
    result, _ = fly_with_model(tmp_path, "small_normal", model)
    assert model.asked["Assessment"] >= 2 and model.asked["Proposal"] == 0
    assert all(d["reasoner"] == "llm:m" for d in records(result, "decision"))
    tools = tools_called(result)
    assert "alerts.notify" not in tools and "flight.land" not in tools and "flight.deploy_payload" not in tools
    assert tools[-1] == "flight.rtl" and result.summary.outcome == "completed"
    assert not list(result.run_dir.glob("alerts/*.eml"))


@pytest.mark.slow
def test_the_patrol_mission_runs_and_logs_crowd_density(tmp_path: Path) -> None:
    result = fly(tmp_path, PATROL, "small_normal", camera_hz=5.0)  # no trigger to confirm: a slower camera will do
    tools = tools_called(result)
    assert tools.count("incidents.log") == 2 and tools[-1] == "flight.rtl"
    assert result.summary.outcome == "completed" and "flight.land" not in tools


@pytest.mark.slow
def test_the_operator_is_asked_and_a_no_sends_the_aircraft_home_without_dropping_the_kit(tmp_path: Path) -> None:
    """--approval ask: the mission graph pauses at the landing (interrupt), the operator says no, the graph resumes
    from its checkpoint and the sub-plan skips what depended on the landing."""
    asked: list[dict[str, Any]] = []

    def operator(request: dict[str, Any]) -> OperatorAnswer:
        asked.append(request)
        return OperatorAnswer(False, "n", "the operator declined")

    settings = RunSettings(
        mission=EMERGENCY, scene=SCENES / "small_emergency.yaml", runs_dir=tmp_path / "runs", params={"rounds": "1"},
        approval="ask", camera_hz=15.0,
    )  # fmt: skip
    result = run_mission(settings, progress=None, operator=operator)
    tools = tools_called(result)
    assert [r["step"] for r in asked] == ["land_near"] and asked[0]["args"]["target_id"].startswith("P-")
    assert "alerts.notify" in tools and "flight.land" not in tools and "flight.deploy_payload" not in tools
    assert [r["status"] for r in records(result, "approval") if "answer" not in r] == ["asked"]
    (approval,) = [r for r in records(result, "approval") if "answer" in r]
    assert approval["via"] == "operator" and approval["answer"] is False and approval["said"] == "n"
    # no mail server in this test: the alerts reached only the outbox, and the run says so
    assert tools[-1] == "flight.rtl" and result.summary.outcome == "degraded"
    # the medical team is told what happened: the alert promised nothing, and the refusal is said
    mails = [email.message_from_bytes(p.read_bytes()) for p in sorted(result.run_dir.glob("alerts/*.eml"))]
    subjects = sorted(str(m["Subject"]) for m in mails)
    assert len(mails) == 2 and tools.count("alerts.notify") == 2, subjects
    assert subjects[0].startswith("Collapsed pilgrim P-") and subjects[1].startswith("No rescue kit for P-")
    assert subjects[1].split()[4] == subjects[0].split()[2] + ":"  # the same id in both
    texts = [_text(m) for m in mails]
    assert any("Kit declined by the operator" in t for t in texts)
    assert not any("on its way" in t for t in texts)


@pytest.mark.slow
def test_the_llm_reasoner_assesses_plans_the_response_and_flies_it(tmp_path: Path, smtp: Any) -> None:
    """--reasoner llm: every assessment is the model's, and on the event the model writes the response plan,
    which passes the checks and is flown: approach, watch, confirm, alert, land beside, drop the kit, home."""
    model = ScriptedModel()
    result, requests = fly_with_model(tmp_path, "small_emergency", model)
    decisions = records(result, "decision")
    assert decisions and all(d["reasoner"] == "llm:m" and d["llm_calls"] == 1 for d in decisions)
    (plan,) = records(result, "plan")
    assert plan["status"] == "ok" and [s["id"] for s in plan["steps"]] == [s["id"] for s in EMERGENCY_PLAN]
    assert '"severity":"high"' in model.plan_prompts[0].replace(" ", "") and "incidents.log(" in model.plan_prompts[0]
    (planned,) = [r for r in records(result, "mission") if r["status"] == "planned"]
    assert planned["by"] == [s["id"] for s in EMERGENCY_PLAN] and not records(result, "refusal")
    steps = {r["step"]: r["status"] for r in records(result, "step")}
    assert all(steps.get(s["id"]) == "ok" for s in EMERGENCY_PLAN), steps
    assert "approach" not in steps  # the mission's own steps were not needed
    tools = tools_called(result)
    for earlier, later in [("alerts.notify", "flight.deploy_payload"), ("flight.land", "flight.deploy_payload")]:
        assert tools.index(earlier) < tools.index(later), tools
    assert [r["request"]["step"] for r in records(result, "approval") if "answer" in r] == ["land_beside", "drop_kit"]
    (envelope,) = smtp.inbox.envelopes
    assert email.message_from_bytes(envelope.content)["Subject"].startswith("Casualty at 21.41")
    assert result.summary.llm_calls == requests == sum(model.asked.values()) and model.asked["Proposal"] == 1


@pytest.mark.slow
def connections_to(port: int) -> int:
    """How many TCP connections this process holds open to ``port`` on this machine (its client side)."""
    mine = set()
    for fd in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):  # the listing's own descriptor is gone by now
            mine.add(os.readlink(f"/proc/self/fd/{fd}"))
    count = 0
    for line in Path("/proc/self/net/tcp").read_text().splitlines()[1:]:
        fields = line.split()
        remote_port, state, inode = int(fields[2].split(":")[1], 16), fields[3], fields[9]
        count += remote_port == port and state == "01" and f"socket:[{inode}]" in mine  # 01: established
    return count


def test_the_hybrid_reasoner_asks_the_model_only_on_the_event_and_refuses_a_plan_beyond_its_scopes(
    tmp_path: Path,
) -> None:
    """Hybrid: the rules read every frame and the model is consulted on the critical event only. Its plan calls a
    tool the agent holds no scope for (and lands unasked): refused before any of it flies, with every reason in
    the trace, and the mission's own steps answer the event instead."""
    greedy = [
        {"id": "unlock", "action": "call_tool", "tool": "payload.override_interlock", "args": {}},
        {"id": "drop_now", "action": "land", "depends_on": ["unlock"], "args": {"target_id": "${event.id}"}},
    ]
    model = ScriptedModel(greedy)
    with StandIn(responder=model) as server:
        settings = RunSettings(
            mission=EMERGENCY, scene=SCENES / "small_emergency.yaml", runs_dir=tmp_path / "runs",
            params={"rounds": "1"}, reasoner="hybrid", llm=f"openai-compatible:m@{server.url}/v1", camera_hz=5.0,
        )  # fmt: skip
        run = MissionRun(settings)
        forbidden = ToolSpec.from_schema(
            "payload.override_interlock", lambda args: "unlocked", {"type": "object"}, scopes=["payload:override"]
        )
        run.registry.register(forbidden)
        result = run.execute()
        calls = len(server.bodies())
        still_open = connections_to(int(server.url.rsplit(":", 1)[1]))
    assert still_open == 0  # the model client the run made is closed with it (before: its connection stayed open)
    decisions = records(result, "decision")
    assert decisions and all(d["focus"] for d in decisions if d["escalated"])  # the model hears of the event only
    assert model.asked["Proposal"] == 1 and 2 <= calls <= 4
    assert sum(d["llm_calls"] for d in decisions) + 1 == calls == result.summary.llm_calls
    (refusal,) = records(result, "refusal")
    assert refusal["status"] == "plan rejected" and "payload:override" in refusal["error"]
    assert "'drop_now': land must ask the operator first" in refusal["error"]
    tools = tools_called(result)
    assert "payload.override_interlock" not in tools and "flight.deploy_payload" in tools  # the playbook's kit drop
    saved = sum(1 for d in decisions if not d["llm_calls"])
    assert result.summary.llm_calls_saved == saved


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["no_such_mission.yaml"], "no_such_mission.yaml"),
        ([str(EMERGENCY), "--scene", "nowhere.yaml"], "nowhere.yaml: no such scene file"),
        ([str(EMERGENCY), "--param", "rounds=many"], "rounds"),
        ([str(EMERGENCY), "--reasoner", "llm"], "needs a model"),
    ],
)
def test_bad_input_is_a_message_and_status_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, args: list[str], message: str
) -> None:
    monkeypatch.delenv("AGENTIC_UAV_LLM", raising=False)
    assert main(["run", *args, "--runs-dir", str(tmp_path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())  # nothing half-made


def _track(result: RunResult) -> list[dict[str, Any]]:
    return [point.model_dump() for point in result.track]


def _attachments(message: Message) -> list[Message]:
    return [part for part in message.walk() if part.get_filename()]


def _text(message: Message) -> str:
    part = next(p for p in message.walk() if p.get_content_type() == "text/plain")
    payload = part.get_payload(decode=True)
    return payload.decode() if isinstance(payload, bytes) else str(payload)
