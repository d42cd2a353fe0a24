"""A swarm run whose mission has the operator verify casualties (``verify: {by: operator}``): the question reaches
the finding UAV's own run — its control port, answered by the run's operator (here a script, as the terminal or the
console would) — and the answer is traced in that UAV's ``trace.jsonl`` and in ``swarm.jsonl``; approved verifies,
declined does not, and silence follows the mission's ``on_timeout``. Nothing flies: the runs are assembled, not
executed, and the casualty is put in the finder's World Model by hand."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agentic_core.agent.control import OperatorAnswer
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.world_model import WorldModel
from agentic_core.run.swarm_run import SwarmRun, SwarmSettings

REPO = Path(__file__).resolve().parents[3]
SHIPPED = REPO / "missions" / "hajj_swarm.yaml"


def _mission(tmp_path: Path, on_timeout: str) -> Path:
    text = SHIPPED.read_text(encoding="utf-8")
    rule = f"verify: {{by: operator, timeout_s: 0.5, on_timeout: {on_timeout}}}"
    path = tmp_path / "operator_swarm.yaml"
    path.write_text(text.replace("verify: {by: uavs, k: 2}", rule), encoding="utf-8")
    return path


def _world(lat0: float, lon0: float) -> WorldModel:
    lat, lon = offset_position(lat0, lon0, 90.0, 10.0)
    pose = {"north": 90.0, "east": 10.0, "down": 0.0, "lat": lat, "lon": lon, "alt": 0.0}
    person = {"id": "T-7", "class": "person", "conf": 0.9, "pose": pose}
    return WorldModel.model_validate({"timestamp": 1.0, "ego_pose": pose, "objects": [person]})


class Script:
    """The operator: answers every question with ``verdict`` (None: never, until released)."""

    def __init__(self, verdict: bool | None) -> None:
        self.verdict = verdict
        self.questions: list[dict[str, Any]] = []
        self.release = threading.Event()

    def __call__(self, request: dict[str, Any]) -> OperatorAnswer:
        self.questions.append(request)
        if self.verdict is None:
            self.release.wait(30.0)
            return OperatorAnswer(False, None, "too late")
        return OperatorAnswer(self.verdict, "y" if self.verdict else "n", "scripted")


@pytest.fixture
def fly(tmp_path: Path) -> Iterator[Any]:
    made: list[tuple[SwarmRun, Script]] = []

    def make(verdict: bool | None, on_timeout: str = "unverified", approval: Any = None) -> tuple[SwarmRun, Script]:
        script = Script(verdict)
        settings = SwarmSettings(mission=_mission(tmp_path, on_timeout), scene=REPO / "scenes" / "hajj_swarm.yaml",
                                 vehicles=2, runs_dir=tmp_path / "runs", a2a=False, operator=script,
                                 approval=approval)  # fmt: skip
        swarm = SwarmRun(settings)
        made.append((swarm, script))
        return swarm, script

    yield make
    for swarm, script in made:
        script.release.set()
        swarm.close()


def _verify(swarm: SwarmRun) -> dict[str, Any]:
    finder = swarm.seats[0]
    world = _world(swarm.home.lat_deg, swarm.home.lon_deg)
    finder.world = lambda: world  # type: ignore[method-assign]
    swarm.coordinator.members[finder.uav].world = lambda: world
    swarm.coordinator.allocate_sectors()
    swarm.coordinator.claim(finder.uav, "T-7")
    return swarm.coordinator.verify(finder.uav, "C1", timeout_s=180.0, wait=lambda: None)


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


@pytest.mark.parametrize(("verdict", "on_timeout", "expected"), [
    (True, "unverified", ("approved", True)), (False, "verified", ("declined", False)),
    (None, "unverified", ("no_answer", False)), (None, "verified", ("no_answer", True)),
])  # fmt: skip
def test_the_finders_operator_answers_on_its_own_runs_port(
    fly: Any, verdict: bool | None, on_timeout: str, expected: tuple[str, bool]
) -> None:
    swarm, script = fly(verdict, on_timeout)
    assert swarm.approval == "ask"  # a mission verified by the operator asks by default
    result = _verify(swarm)
    assert (result["answer"], result["verified"]) == expected
    (question,) = script.questions
    assert question["args"]["casualty"] == "C1" and swarm.seats[0].uav in question["question"]
    (record,) = [r for r in _lines(swarm.dir / "swarm.jsonl") if r["event"] == "verify"]
    assert (record["by"], record["answer"], record["verified"]) == ("operator", *expected)
    run_dir = swarm.seats[0].run.run_dir
    approvals = [r for r in _lines(run_dir / "trace.jsonl") if r["kind"] == "approval"]
    assert [a.get("status") for a in approvals] == ["asked", None]
    assert approvals[1]["verdict"] == expected[0] and approvals[1]["via"] == "operator"
    assert swarm.coordinator.casualties["C1"].verified is expected[1]


def test_a_headless_swarm_run_answers_by_its_policy(fly: Any) -> None:
    swarm, script = fly(True, approval="decline")  # --approval decline: nobody is asked
    assert _verify(swarm)["answer"] == "declined" and script.questions == []
    run_dir = swarm.seats[0].run.run_dir
    approvals = [r for r in _lines(run_dir / "trace.jsonl") if r["kind"] == "approval"]
    assert approvals[-1]["via"] == "policy" and approvals[-1]["answer"] is False


@pytest.mark.slow
@pytest.mark.timeout(600)
@pytest.mark.parametrize("approve", [True, False])
def test_flown_the_operators_answer_decides_the_alert(tmp_path: Path, smtp: Any, approve: bool) -> None:
    script = Script(approve)
    mission = _mission(tmp_path, "unverified").read_text(encoding="utf-8")
    path = tmp_path / "flown.yaml"
    two_uavs = mission.replace("timeout_s: 0.5", "timeout_s: 60").replace("spacing_m: 50", "spacing_m: 25")
    # two strips twice as wide: lanes half as far apart; and the operator judges every claimed casualty, however
    # severe the finder's own reasoner found it
    operator_judges = two_uavs.replace(""", "confirm.assessment.severity == 'critical'"]""", "]")
    assert operator_judges != two_uavs
    path.write_text(operator_judges, encoding="utf-8")
    settings = SwarmSettings(mission=path, scene=REPO / "scenes" / "hajj_swarm.yaml", vehicles=2, speed=None,
                             runs_dir=tmp_path / "runs", camera_hz=5.0, operator=script)  # fmt: skip
    swarm = SwarmRun(settings)
    summary = swarm.execute()
    (casualty,) = [c for c in summary["casualties"] if c["truth"] == "P-12"]
    (question,) = script.questions  # one question, the finder's
    assert question["args"]["casualty"] == casualty["id"] and casualty["found_by"] in question["question"]
    assert casualty["verified"] is approve and casualty["alerted"] is approve
    assert len(smtp.inbox.envelopes) == (1 if approve else 0)
    finder = Path(summary["uavs"][casualty["found_by"]]["run_dir"])
    answered = [r for r in _lines(finder / "trace.jsonl") if r["kind"] == "approval" and r.get("verdict")]
    assert [a["verdict"] for a in answered] == ["approved" if approve else "declined"]
    if not approve:  # declined: the alert step was skipped, and the run says so
        skipped = [r for r in _lines(finder / "trace.jsonl") if r.get("step") == "alert_medics"]
        assert skipped and not [r for r in _lines(finder / "trace.jsonl")
                                if r["kind"] == "tool" and r.get("name") == "alerts.notify"
                                and (r.get("args") or {}).get("channel") == "email"]  # fmt: skip
