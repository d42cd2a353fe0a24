"""The control port is heard during the long flight actions the triggers do not watch: a take-off climbing and a
MAVLink mission the autopilot flies on its own. Before, an abort waited for the climb to end, or for the whole
mission (up to an hour); now it ends them with a hold at once and the mission's ``on_abort`` follows."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from agentic_core.contracts import TelemetrySample
from agentic_core.run.runner import MissionRun, RunSettings
from tests.waiting import wait_for

from .conftest import REPO, fly_steered, of_kind, telemetry, trace

NORMAL = REPO / "tests" / "agentic_core" / "run" / "scenes" / "small_normal.yaml"
FENCE = """
limits:
  geofence:
    - {lat: 21.4090, lon: 39.8870}
    - {lat: 21.4090, lon: 39.9000}
    - {lat: 21.4180, lon: 39.9000}
    - {lat: 21.4180, lon: 39.8870}
  max_altitude_m: 60
"""
SURVEY = [(21.4133, 39.8990), (21.4150, 39.8950)]
"""Two legs (590 m east, then 460 m back north-west) the autopilot flies on its own, at 40 m."""


def survey_mission(path: Path, on_abort: str | None = None) -> Path:
    items = ", ".join(f"{{command: 16, lat: {lat}, lon: {lon}, alt: 40}}" for lat, lon in SURVEY)
    path.write_text(
        "plan_id: survey\ngoal: Fly a survey the autopilot flies on its own.\n" + FENCE
        + (f"on_abort: {on_abort}\n" if on_abort else "")
        + "steps:\n"
        "  - {id: climb, action: takeoff, args: {altitude_m: 40}}\n"
        f"  - {{id: upload, action: call_tool, tool: flight.upload_mission, args: {{items: [{items}]}},"
        " depends_on: [climb]}\n"
        "  - {id: survey, action: call_tool, tool: flight.start_mission, args: {wait: true}, depends_on: [upload]}\n"
        "  - {id: go_home, action: rtl, depends_on: [survey]}\n",
        encoding="utf-8",
    )  # fmt: skip
    return path


def start(path: Path, tmp_path: Path) -> MissionRun:
    return MissionRun(RunSettings(mission=path, scene=NORMAL, runs_dir=tmp_path / "runs", camera_hz=2.0))


def test_an_abort_during_a_mavlink_mission_ends_it_at_once_and_the_aircraft_comes_home(tmp_path: Path) -> None:
    run = start(survey_mission(tmp_path / "survey.yaml"), tmp_path)
    asked: list[float] = []

    def operator() -> None:  # once the autopilot flies the survey's first leg
        wait_for(lambda: run.last_sample is not None and run.last_sample.mode == "mission"
                 and math.hypot(run.last_sample.vn_mps, run.last_sample.ve_mps) > 3.0,
                 timeout_s=120.0, what="the survey under way")  # fmt: skip
        asked.append(run.clock())
        run.control.abort("a helicopter in the area", by="tester")

    result = fly_steered(run, operator)
    assert asked and result.summary.outcome == "aborted"
    records = trace(result.run_dir)
    tools = of_kind(records, "tool")
    (stopped,) = [r for r in tools if r.get("name") == "flight.start_mission"]
    assert stopped["status"] == "interrupted" and "abort" in stopped["summary"]
    (home,) = [r for r in tools if r.get("name") == "flight.rtl" and r.get("status") == "ok"]
    flown = telemetry(result.run_dir)
    turned = next(t["time_s"] for t in flown if t["time_s"] > asked[0] and t["mode"] in ("hold", "rtl"))
    # asked from another thread, at a moment the run's clock only approximates: within seconds, not at the survey's
    # end (the exact simulated moment is measured by the full-speed test below)
    assert turned - asked[0] < 2.0, (asked[0], turned)
    farthest = max(math.hypot(t["north_m"], t["east_m"]) for t in flown)
    assert farthest < 500.0, farthest  # the first leg alone is 590 m: it never got to its end
    last = flown[-1]
    assert last["alt_m"] < 0.5 and math.hypot(last["north_m"], last["east_m"]) < 3.0
    assert home["sim_t"] > asked[0]


@pytest.mark.slow
@pytest.mark.parametrize("command", ["abort", "pause"])
def test_the_operator_is_heard_during_the_climb(tmp_path: Path, command: str) -> None:
    """An abort while climbing to 40 m lands where it is (``on_abort: land``) without climbing on; a pause holds
    the climb, and after resume the climb and the survey go on to the end."""
    run = start(survey_mission(tmp_path / "survey.yaml", on_abort="land"), tmp_path)
    asked: list[float] = []

    def operator() -> None:
        wait_for(lambda: run.last_sample is not None and run.last_sample.alt_m > 8.0, timeout_s=120.0,
                 what="the climb under way")  # fmt: skip
        asked.append(run.last_sample.alt_m if run.last_sample is not None else math.nan)
        if command == "abort":
            run.control.abort("wind", by="tester")
            return
        run.control.pause(by="tester")
        paused = run.clock()
        try:
            wait_for(lambda: run.clock() >= paused + 5.0, timeout_s=60.0, what="five seconds paused")
            asked.append(run.last_sample.alt_m if run.last_sample is not None else math.nan)
        finally:
            run.control.resume(by="tester")

    result = fly_steered(run, operator)
    flown = telemetry(result.run_dir)
    climb = [r for r in of_kind(trace(result.run_dir), "tool") if r.get("name") == "flight.takeoff"]
    assert climb[0]["status"] == "interrupted", climb
    if command == "abort":
        assert result.summary.outcome == "aborted"
        assert max(t["alt_m"] for t in flown) < 25.0  # it stopped climbing: 40 m was never near
        assert flown[-1]["alt_m"] < 0.5
    else:
        assert result.summary.outcome == "completed"
        assert len(asked) == 2 and asked[1] < 25.0, asked  # held, not climbing on to 40 m meanwhile
        assert [r["status"] for r in climb] == ["interrupted", "ok"]
        assert max(t["alt_m"] for t in flown) > 38.0


def legs_mission(path: Path) -> Path:
    """The survey's two legs flown as the agent's own ``fly_to`` steps (watched), not by the autopilot."""
    (first, second) = SURVEY
    path.write_text(
        "plan_id: legs\ngoal: Fly two legs.\n" + FENCE + "steps:\n"
        "  - {id: climb, action: takeoff, args: {altitude_m: 40}}\n"
        f"  - {{id: east, action: fly_to, args: {{lat: {first[0]}, lon: {first[1]}, alt_m: 40}},"
        " depends_on: [climb]}\n"
        f"  - {{id: back, action: fly_to, args: {{lat: {second[0]}, lon: {second[1]}, alt_m: 40}},"
        " depends_on: [east]}\n"
        "  - {id: go_home, action: rtl, depends_on: [back]}\n",
        encoding="utf-8",
    )  # fmt: skip
    return path


@pytest.mark.slow
@pytest.mark.parametrize(("flown_by", "tool"), [("autopilot", "flight.start_mission"), ("agent", "flight.fly_to")])
def test_at_full_speed_a_stop_acts_at_the_simulated_moment_it_was_sent(
    tmp_path: Path, flown_by: str, tool: str
) -> None:
    """Headless, the simulation runs many times faster than real time; the dispatcher must not let it fly on for the
    wall-clock moment it takes to notice the operator. The abort is sent from the vehicle's own telemetry hook, so
    the simulated time it was sent at is exact; the vehicle must act on the hold within a quarter second of flight,
    not the second or more a 50 ms poll is worth at full speed (0.56–0.68 s measured before, on a busy machine).

    When the vehicle acted: for the autopilot's mission, the first tick it reports Hold; for the agent's own leg
    (a reposition, flown in Hold already), the end of the interrupted action, which waits for the hold's ack."""
    mission = survey_mission(tmp_path / "m.yaml") if flown_by == "autopilot" else legs_mission(tmp_path / "m.yaml")
    run = start(mission, tmp_path)
    sent: list[float] = []
    held: list[float] = []

    def hook(sample: TelemetrySample) -> None:  # the simulation's thread, every tick
        if sent:
            if not held and sample.mode == "hold":
                held.append(sample.time_s)
        elif (flown_by == "agent" or sample.mode == "mission") and 150.0 < sample.east_m < 400.0:  # mid-leg
            sent.append(sample.time_s)
            run.control.abort("traffic", by="tester")

    run.backend.on_sample(hook)
    result = run.execute()
    assert sent and result.summary.outcome == "aborted"
    tools = of_kind(trace(result.run_dir), "tool")
    (stopped,) = [r for r in tools if r.get("name") == tool and r.get("status") == "interrupted"]
    assert stopped["hold"] == "ok"
    acted = held[0] if flown_by == "autopilot" else stopped["sim_t"]
    assert 0.0 <= acted - round(sent[0], 3) < 0.25, (sent, acted)  # the trace gives sim_t to the millisecond
