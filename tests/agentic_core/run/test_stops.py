"""What a stop does to the aircraft, and the take-off again of a resumed run that a stop brought down."""

from __future__ import annotations

from typing import Any

import pytest

from agentic_core.run.stops import carry_out, stop_tool, take_off_again

LIFT = {"kind": "tool", "name": "flight.takeoff", "status": "ok", "args": {"altitude_m": 30}}
STOP = {"kind": "control", "command": "abort", "by": "operator"}
DOWN = {"landed_state": "on_ground", "armed": False}


def calls_of(records: list[dict[str, Any]], view: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    made: list[tuple[str, dict[str, Any]]] = []
    take_off_again(records, view, lambda name, args: made.append((name, args)), lambda *a, **k: None)
    return made


def test_a_resumed_run_that_a_stop_brought_down_takes_off_to_the_height_it_last_took_off_to() -> None:
    higher = {**LIFT, "args": {"altitude_m": 45}}
    assert calls_of([LIFT, higher, STOP], DOWN) == [("flight.takeoff", {"altitude_m": 45})]


@pytest.mark.parametrize(
    ("records", "view"),
    [
        ([LIFT, STOP], {"landed_state": "in_air", "armed": True}),  # still flying: nothing to do
        ([LIFT, STOP], {"landed_state": "on_ground", "armed": True}),  # armed on the ground: not brought down
        ([LIFT], DOWN),  # the mission itself landed (no stop): its own steps take off again
        ([STOP], DOWN),  # never took off: nothing to go back to
        ([{**LIFT, "status": "error"}, STOP], DOWN),  # a take-off that failed is no height to go back to
    ],
)
def test_nothing_takes_off_unless_a_stop_brought_a_flying_aircraft_down(
    records: list[dict[str, Any]], view: dict[str, Any]
) -> None:
    assert calls_of(records, view) == []


def test_a_signal_holds_and_an_operators_abort_does_what_the_mission_says() -> None:
    assert stop_tool("abort", "rtl", by="signal") == "flight.hold"
    assert [stop_tool("abort", on) for on in ("rtl", "land", "hold")] == ["flight.rtl", "flight.land", "flight.hold"]
    assert stop_tool("rtl", "hold") == "flight.rtl"  # an explicit stop is what it says, whatever on_abort is
    made: list[str] = []
    carry_out("land", "rtl", DOWN, lambda name, args: made.append(name), lambda *a, **k: None)
    assert made == []  # a landing asked of an aircraft on the ground, disarmed: nothing to send
    carry_out(
        "abort", "land", {"landed_state": "in_air", "armed": True}, lambda n, a: made.append(n), lambda *a, **k: None
    )
    assert made == ["flight.land"]
