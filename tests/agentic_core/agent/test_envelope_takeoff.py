"""A take-off is checked against the geofence from where the aircraft stands (its reported position, else home):
one standing outside is refused before anything is sent, one inside goes; ``validate`` refuses a mission whose
home (``--home``, the scene's) lies outside its fence, at the take-off step's line."""

from __future__ import annotations

from pathlib import Path

import pytest

from agentic_core.agent.envelope import Envelope
from agentic_core.cli import main
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.policy_graph import Limits
from agentic_core.mission import MissionError, load_mission

from .fakes import Aircraft, executor_for
from .stand_ins import PlainExecutor
from .test_dispatch_keys import dispatcher, run

HOME = (21.4133, 39.8933)
FENCE_NORTH_M = 111.0  # the tester's case: the fence's centre 111 m north of home, radius 50 m
CENTRE = offset_position(*HOME, FENCE_NORTH_M, 0.0)
CIRCLE = Limits.model_validate({"geofence": {"center": {"lat": CENTRE[0], "lon": CENTRE[1]}, "radius_m": 50}})
CORNERS = [offset_position(*HOME, n, e) for n, e in ((61, -50), (61, 50), (161, 50), (161, -50))]
SQUARE = Limits.model_validate({"geofence": [{"lat": lat, "lon": lon} for lat, lon in CORNERS]})
MISSION = """plan_id: homeout
goal: home lies outside the mission's fence
limits:
  geofence: {{center: {{lat: {lat}, lon: {lon}}}, radius_m: 50}}
steps:
  - {{id: up, action: takeoff, args: {{altitude_m: 10}}}}
  - {{id: home, action: rtl, depends_on: [up]}}
"""


@pytest.mark.parametrize("limits", [CIRCLE, SQUARE], ids=["circle", "polygon"])
def test_a_takeoff_from_home_outside_the_fence_is_refused(limits: Limits) -> None:
    problems = Envelope(limits, home=lambda: HOME).check("flight.takeoff", {"altitude_m": 10.0})
    assert len(problems) == 1 and "61 m outside the geofence" in problems[0], problems


@pytest.mark.parametrize("limits", [CIRCLE, SQUARE], ids=["circle", "polygon"])
def test_the_reported_position_decides_not_home(limits: Limits) -> None:
    inside = offset_position(*HOME, FENCE_NORTH_M, 10.0)
    env = Envelope(limits, home=lambda: HOME, position=lambda: inside)
    assert env.check("flight.takeoff", {"altitude_m": 10.0}) == []
    far = offset_position(*HOME, FENCE_NORTH_M + 90.0, 0.0)  # past the fence on the other side, home aside
    env = Envelope(limits, home=lambda: HOME, position=lambda: far)
    problems = env.check("flight.takeoff", {})
    assert len(problems) == 1 and "40 m outside the geofence" in problems[0], problems


def test_without_a_fence_home_or_position_a_takeoff_is_only_checked_for_height() -> None:
    assert Envelope(Limits(max_altitude_m=25), home=lambda: HOME).check("flight.takeoff", {"altitude_m": 10}) == []
    assert Envelope(CIRCLE, home=lambda: None).check("flight.takeoff", {"altitude_m": 10}) == []
    ceiling = CIRCLE.model_copy(update={"max_altitude_m": 25})
    problems = Envelope(ceiling, home=lambda: HOME).check("flight.takeoff", {"altitude_m": 30})
    assert len(problems) == 2 and "ceiling" in problems[1], problems


def test_validate_refuses_a_takeoff_from_a_home_outside_the_fence_at_its_line() -> None:
    text = MISSION.format(lat=CENTRE[0], lon=CENTRE[1])
    with pytest.raises(MissionError) as caught:
        load_mission(text, file="homeout.yaml", home=HOME)
    [problem] = caught.value.problems
    assert (problem.file, problem.line) == ("homeout.yaml", 6)
    assert "takeoff: home is 61 m outside the geofence" in problem.message
    assert load_mission(text, file="homeout.yaml").plan_id == "homeout"  # home unknown: checked in flight only
    inside = MISSION.format(lat=HOME[0], lon=HOME[1])
    assert load_mission(inside, file="ok.yaml", home=HOME).plan_id == "homeout"


def test_the_validate_command_uses_home_from_its_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "homeout.yaml"
    path.write_text(MISSION.format(lat=CENTRE[0], lon=CENTRE[1]), encoding="utf-8")
    assert main(["validate", str(path), "--home", f"{HOME[0]},{HOME[1]}"]) == 2
    assert f"{path}:6:" in capsys.readouterr().err
    assert main(["validate", str(path), "--home", f"{CENTRE[0]},{CENTRE[1]}"]) == 0


def test_the_dispatcher_never_sends_a_takeoff_from_outside_the_fence() -> None:
    executor = PlainExecutor(executor_for(Aircraft(instant=True)))
    envelope = Envelope(CIRCLE, home=lambda: HOME)
    text = MISSION.format(lat=CENTRE[0], lon=CENTRE[1])
    out = run(text, dispatcher(executor, envelope=envelope))
    assert out["status"]["up"] == "failed"
    assert "outside the flight envelope" in str(out["errors"]["up"]) and "61 m outside" in str(out["errors"]["up"])
    assert "flight.takeoff" not in [tool for tool, *_ in executor.calls]
    inside = PlainExecutor(executor_for(Aircraft(instant=True)))
    run(text, dispatcher(inside, envelope=Envelope(CIRCLE, home=lambda: CENTRE)))
    assert "flight.takeoff" in [tool for tool, *_ in inside.calls]
