"""A mission's ``scopes:`` must hold what the run itself calls (``flight.status`` to reach the vehicle, the fence,
hold, return, land) and what every tool of its steps and triggers asks: ``validate`` says which scope is missing and
for what, at the line of ``scopes:``, and ``run`` refuses the file the same way (exit 2) before anything flies."""

from __future__ import annotations

from pathlib import Path

import pytest

from agentic_core.cli import main
from agentic_core.mission import MissionError, load_mission
from agentic_core.mission.validate import check_revision
from agentic_core.run.own_tools import register_stand_ins
from tools import ToolRegistry
from tools.loading import build_registry

BODY = """plan_id: scoped
goal: fly a little
scopes: {scopes}
steps:
  - {{id: up, action: takeoff, args: {{altitude_m: 10}}}}
  - {{id: look, action: analyze_scene, depends_on: [up]}}
  - {{id: home, action: rtl, depends_on: [look]}}
triggers:
  - id: smoke
    when: "count(world.objects, class_='smoke') > 0"
    steps:
      - {{id: tell, action: call_tool, tool: alerts.notify, args: {{subject: smoke, body: seen, channel: log}}}}
"""
ENOUGH = "[flight:read, flight:command, perception:read, alerts:send]"


def _catalogue() -> ToolRegistry:
    registry = build_registry(plugins=False)
    register_stand_ins(registry)
    return registry


def _problems(scopes: str) -> list[str]:
    with pytest.raises(MissionError) as caught:
        load_mission(BODY.format(scopes=scopes), file="m.yaml", tools=_catalogue())
    return [f"{p.file}:{p.line}:{p.col}: {p.message}" for p in caught.value.problems]


@pytest.mark.parametrize(
    ("scopes", "missing", "absent"),
    [
        ("[]", ["flight:read", "flight:command", "perception:read", "alerts:send"], []),
        ("[flight:command, perception:read, alerts:send]", ["flight:read (for flight.status in the run itself)"],
         ["flight:command", "alerts:send"]),
        ("[flight:read, flight:command, perception:read]", ["alerts:send (for alerts.notify in step 'tell')"],
         ["flight:read", "perception"]),
        ("['flight:*', alerts:send]", ["perception:read (for perception.analyze_scene in step 'look')"],
         ["flight:"]),
    ],
    ids=["empty", "no-telemetry", "trigger-tool", "wildcard"],
)  # fmt: skip
def test_scopes_leaving_out_what_the_run_needs_fail_at_their_line(
    scopes: str, missing: list[str], absent: list[str]
) -> None:
    [problem] = _problems(scopes)
    assert problem.startswith("m.yaml:3:9: scopes leaves out "), problem
    for text in missing:
        assert text in problem, (text, problem)
    head = problem.split(", which")[0]
    for text in absent:
        assert text not in head, (text, problem)


@pytest.mark.parametrize("scopes", [ENOUGH, "['flight:*', 'perception:*', 'alerts:*']"])
def test_scopes_holding_everything_pass(scopes: str) -> None:
    assert load_mission(BODY.format(scopes=scopes), file="m.yaml", tools=_catalogue()).plan_id == "scoped"


def test_without_scopes_or_a_catalogue_nothing_is_asked() -> None:
    text = BODY.format(scopes="[]").replace("scopes: []\n", "")
    assert load_mission(text, file="m.yaml", tools=_catalogue()).plan_id == "scoped"
    assert load_mission(BODY.format(scopes="[]"), file="m.yaml").plan_id == "scoped"


def test_a_revision_is_not_blamed_for_the_missions_scopes() -> None:
    plan = load_mission(BODY.format(scopes="[]"), file="m.yaml")  # no catalogue: loads
    steps = plan.steps[:1]
    assert (
        check_revision(plan, [steps[0].model_copy(update={"id": "again"})], ["up", "look", "home"], _catalogue()) == []
    )


def test_validate_and_run_refuse_the_mission_with_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "scopes_cmd.yaml"
    path.write_text(BODY.format(scopes="[flight:command, perception:read, alerts:send]"), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:3:9: scopes leaves out flight:read" in err and "Traceback" not in err
    runs = tmp_path / "runs"
    assert main(["run", str(path), "--runs-dir", str(runs), "--quiet", "--gcs", "none"]) == 2
    err = capsys.readouterr().err
    assert "scopes leaves out flight:read" in err and "cannot reach the vehicle" not in err
