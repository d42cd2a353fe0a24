"""The fault schedule a user writes: ``--fault`` and a scene's ``faults:``, parsed into :class:`Fault` with errors
naming the flag or file:line (exit 2); delivered when due — mission time or a step's completion — once each."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError

from agentic_core.cli import main
from agentic_core.contracts import RunEvent, TelemetrySample
from agentic_core.contracts.faults import Fault, parse_fault
from agentic_core.contracts.tool_result import ToolResult
from agentic_core.mission.compile import STEPS_ADAPTER
from agentic_core.run.faults import SCHEDULE, FaultSchedule
from agentic_core.run.plan_review import review
from agentic_core.run.settings import AGENT
from flight.client.safety import failure_command
from flight.sim.scene_file import SceneFileError, load_scene
from flight.tools import register_flight_tools
from flight.vehicle import VehicleClient
from tools import ToolExecutor, ToolRegistry

from .conftest import EXAMPLES


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("battery@S1", "battery needs a level"),
        ("battery=18@S1", "is a percentage"),
        ("battery=-5%@S1", "0 to 100 percent"),
        ("battery=101%@S1", "0 to 100 percent"),
        ("battery=nan%@S1", "0 to 100 percent"),
        ("battery=x%@S1", "is not a number"),
        ("motor@t=3s", "motor needs its number"),
        ("motor=5@t=3s", "motor needs its number"),
        ("motor=1.5@t=3s", "motor needs its number"),
        ("gps_loss=1@t=3s", "gps_loss takes no value"),
        ("gps_loss", "expected KIND[=VALUE]@WHEN"),
        ("gps_loss@", "is not a time"),
        ("gps_loss@t=-3s", "is not a time"),
        ("gps_loss@t=3m", "is not a time"),
        ("gps_loss@S1;rm -rf", "is not a time"),
        ("engine_fire@t=3s", "no fault 'engine_fire'"),
        ("", "expected KIND[=VALUE]@WHEN"),
    ],
)
def test_a_fault_that_cannot_be_read_says_what_is_wrong(text: str, why: str) -> None:
    with pytest.raises(ValueError, match=r".*") as caught:
        parse_fault(text)
    assert why in str(caught.value) and repr(text) in str(caught.value)


def test_the_text_form_round_trips_and_maps_onto_mav_cmd_inject_failure() -> None:
    for text in ("battery=18%@S1", "battery_low@t=12.5s", "battery_critical@S2", "gps_loss@t=40s",
                 "link_loss@t=3s", "motor=2@wp1"):  # fmt: skip
        fault = parse_fault(text)
        assert parse_fault(fault.text()) == fault and Fault.model_validate(text) == fault
    assert failure_command("battery", 18.0) == (100, 4, 0, 18.0)  # SYSTEM_BATTERY, WRONG, param4 the level
    assert failure_command("motor", 2.0) == (101, 1, 2, None)
    assert failure_command("gps_loss") == (4, 1, 0, None)
    with pytest.raises(ValueError, match="no fault"):
        failure_command("engine_fire")


def test_a_fault_mapping_needs_exactly_one_time() -> None:
    with pytest.raises(ValidationError, match="one time"):
        Fault.model_validate({"fault": "gps_loss", "at_s": 3, "at_step": "S1"})
    with pytest.raises(ValidationError, match="one time"):
        Fault.model_validate({"fault": "gps_loss"})


def test_a_bad_fault_flag_exits_2_naming_the_flag(tmp_path: Path, capsys: Any) -> None:
    code = main(["run", str(EXAMPLES / "square_15m.yaml"), "--runs-dir", str(tmp_path), "--quiet",
                 "--fault", "gps_loss@t=3s", "--fault", "battery=18@S1"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and "--fault 'battery=18@S1'" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not list(tmp_path.iterdir())  # nothing was flown


def test_faults_cannot_be_changed_on_resume(tmp_path: Path, capsys: Any) -> None:
    code = main(["run", "--resume", "x", "--runs-dir", str(tmp_path), "--fault", "gps_loss@t=3s"])
    assert code == 2 and "faults" in capsys.readouterr().err


def test_a_bad_fault_in_a_scene_file_is_named_at_its_line() -> None:
    text = "id: trap\nfaults:\n  - gps_loss@t=40s\n  - battery=180%@S1\n"
    with pytest.raises(SceneFileError) as caught:
        load_scene(text, file="trap.yaml")
    assert str(caught.value).startswith("trap.yaml:4:5: faults[1]:") and "0 to 100 percent" in str(caught.value)
    assert load_scene(text.replace("180%", "18%"), file="trap.yaml").faults[1] == parse_fault("battery=18%@S1")


class Injector:
    """Stands in for the executor: records each call, answers as told."""

    def __init__(self, status: str = "ok", error: str | None = None) -> None:
        self.calls: list[dict[str, Any]] = []
        self.status, self.error = status, error
        self.done = threading.Event()

    def __call__(self, name: str, args: Any) -> ToolResult:
        assert name == "flight.inject_failure"
        self.calls.append(dict(args))
        self.done.set()
        return ToolResult(call_id=f"c{len(self.calls)}", tool=name, status=self.status, error=self.error,
                          latency_s=0.0, attempts=1)  # fmt: skip


class Said:
    def __init__(self) -> None:
        self.events: list[dict[str, Any]] = []

    def __call__(self, kind: str, /, **fields: Any) -> None:
        assert kind == "fault"
        self.events.append(fields)


def tick(t: float) -> TelemetrySample:
    return TelemetrySample(time_s=t, lat_deg=21.4, lon_deg=39.9, alt_m=10, north_m=0, east_m=0, down_m=-10)


def step(name: str, status: str) -> RunEvent:
    return RunEvent(kind="step", step=name, status=status)


def test_faults_fall_due_on_mission_time_and_on_a_step_completing_each_once() -> None:
    inject, said = Injector(), Said()
    faults = [parse_fault(t) for t in ("gps_loss@t=10s", "battery=18%@S1", "motor=3@S2")]
    schedule = FaultSchedule(faults, inject, said)
    schedule.start()
    schedule.on_sample(tick(500.0))  # mission time starts at the first sample: the vehicle may have booted long ago
    schedule.on_sample(tick(509.9))
    schedule.on_event(step("S1", "running"))
    schedule.on_event(step("S1", "failed"))
    schedule.on_event(RunEvent(kind="tool", step="S1", status="ok"))
    assert inject.calls == []
    schedule.on_sample(tick(510.0))
    schedule.on_event(step("S1", "ok"))
    schedule.on_event(step("S1", "ok"))  # a repeat's second pass: already delivered
    schedule.on_sample(tick(520.0))
    schedule.close()
    assert inject.calls == [{"fault": "gps_loss"}, {"fault": "battery", "value": 18.0}]
    assert [e["fault"] for e in said.events] == ["gps_loss@t=10s", "battery=18%@S1", "motor=3@S2"]
    assert [e["status"] for e in said.events] == ["ok", "ok", "not_due"]


def test_a_refused_injection_is_reported_with_the_vehicle_reason() -> None:
    inject = Injector("error", "the vehicle said: unsupported (UNSUPPORTED)")
    said = Said()
    schedule = FaultSchedule([parse_fault("battery=18%@t=0s")], inject, said)
    schedule.start()
    schedule.on_sample(tick(1.0))
    assert inject.done.wait(10.0)
    schedule.close()
    (event,) = said.events
    assert event["status"] == "error" and "not injected: the vehicle said: unsupported" in event["summary"]


def test_a_resumed_run_does_not_deliver_a_fault_twice() -> None:
    inject, said = Injector(), Said()
    schedule = FaultSchedule([parse_fault("gps_loss@t=1s"), parse_fault("link_loss@t=2s")], inject, said,
                             delivered=["gps_loss@t=1s"])  # fmt: skip
    schedule.start()
    schedule.on_sample(tick(0.0))
    schedule.on_sample(tick(5.0))
    schedule.close()
    assert inject.calls == [{"fault": "link_loss"}]


def test_nothing_to_deliver_starts_no_thread() -> None:
    schedule = FaultSchedule([], Injector(), Said())
    schedule.start()
    assert schedule._thread is None
    schedule.close()


def test_the_agent_cannot_inject_a_fault_itself_only_the_schedule_can() -> None:
    """``flight.inject_failure`` needs ``flight:fault``: a model's plan that calls it is refused whole by the scope
    review, and a direct call as the agent is refused by the executor before anything reaches a vehicle."""
    registry = ToolRegistry()

    async def never() -> VehicleClient:
        raise AssertionError("nothing may reach the vehicle")

    register_flight_tools(registry, never)
    steps = STEPS_ADAPTER.validate_python(
        [{"id": "sabotage", "action": "call_tool", "tool": "flight.inject_failure",
          "args": {"fault": "motor", "value": 1}}]
    )  # fmt: skip
    assert review(steps, registry, AGENT) == [
        "step 'sabotage': flight.inject_failure needs scope flight:fault, which the agent lacks"
    ]
    with ToolExecutor(registry, default_caller=AGENT) as executor:
        denied = executor.call("flight.inject_failure", {"fault": "motor", "value": 1})
        assert denied.status == "denied" and "flight:fault" in str(denied.error)
        bad = executor.call("flight.inject_failure", {"fault": "motor", "value": 9}, caller=SCHEDULE)
        assert bad.status == "error" and "motor needs its number" in str(bad.error)  # checked before connecting
