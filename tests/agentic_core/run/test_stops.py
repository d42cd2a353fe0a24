"""What a stop does to the aircraft, and how a resumed run goes back to where a stop took the aircraft from."""

from __future__ import annotations

from typing import Any

import pytest

from agentic_core.contracts.geodesy import ned_to_geodetic
from agentic_core.contracts.telemetry import TelemetrySample
from agentic_core.run.stops import GONE_M, carry_out, go_back, stop_tool, where_it_ended

LIFT = {"kind": "tool", "name": "flight.takeoff", "status": "ok", "args": {"altitude_m": 30}}
STOP = {"kind": "control", "command": "abort", "by": "operator"}
HOME = {"lat_deg": 21.4133, "lon_deg": 39.8933, "alt_m": 0.0}
DOWN = {**HOME, "landed_state": "on_ground", "armed": False}
AWAY = {"lat": 21.4136, "lon": 39.8934, "alt_m": 15.8}  # about 35 m north of home
GONE = {"kind": "log", "stopped_at": {**AWAY, "landed": False}}

Calls = list[tuple[str, dict[str, Any]]]


def calls_of(records: list[dict[str, Any]], view: dict[str, Any]) -> Calls:
    made: Calls = []
    go_back(records, view, lambda name, args: made.append((name, args)), lambda *a, **k: None)
    return made


def test_a_resumed_run_that_a_stop_brought_down_takes_off_to_the_height_it_last_took_off_to() -> None:
    higher = {**LIFT, "args": {"altitude_m": 45}}
    assert calls_of([LIFT, higher, STOP, GONE], DOWN)[0] == ("flight.takeoff", {"altitude_m": 45})


def test_it_then_flies_back_to_where_the_stop_found_it() -> None:
    assert calls_of([LIFT, STOP, GONE], DOWN) == [("flight.takeoff", {"altitude_m": 30}), ("flight.fly_to", AWAY)]


def test_found_landed_beside_someone_it_flies_back_at_its_height_and_lands_there_again() -> None:
    beside = {"kind": "log", "stopped_at": {**AWAY, "alt_m": 0.1, "landed": True}}
    spot = {"lat": AWAY["lat"], "lon": AWAY["lon"]}
    assert calls_of([LIFT, STOP, beside], DOWN) == [
        ("flight.takeoff", {"altitude_m": 30}), ("flight.fly_to", {**spot, "alt_m": None}), ("flight.land", spot),
    ]  # fmt: skip
    flying = {**HOME, "landed_state": "in_air", "armed": True, "alt_m": 30.0}  # an RTL cut short by the stop
    assert calls_of([LIFT, STOP, GONE], flying) == [("flight.fly_to", AWAY)]


def test_close_enough_to_where_it_stopped_it_does_not_move() -> None:
    lat, lon, _ = ned_to_geodetic(GONE_M * 0.9, 0.0, 0.0, AWAY["lat"], AWAY["lon"], 0.0)
    here = {"lat_deg": lat, "lon_deg": lon, "alt_m": 15.0, "landed_state": "in_air", "armed": True}
    assert calls_of([LIFT, STOP, GONE], here) == []


@pytest.mark.parametrize(
    ("records", "view"),
    [
        ([LIFT, STOP], {**HOME, "landed_state": "in_air", "armed": True}),  # still flying, held: nothing to do
        ([LIFT, STOP], DOWN),  # the stop found it on the ground, disarmed (landed beside someone): it stays there
        ([LIFT], DOWN),  # the mission itself landed (no stop): its own steps take off again
        ([LIFT, GONE], DOWN),  # a position with no stop: nothing to go back to
        ([LIFT, STOP, GONE, STOP], DOWN),  # the last stop is what counts, and it said nothing of where it was
        ([{**LIFT, "status": "error"}, STOP], DOWN),  # a take-off that failed is no height to go back to
    ],
)
def test_nothing_moves_unless_a_stop_took_a_flying_aircraft_away(
    records: list[dict[str, Any]], view: dict[str, Any]
) -> None:
    assert calls_of(records, view) == []


def test_an_abort_by_anyone_does_what_the_mission_says() -> None:
    assert [stop_tool("abort", on) for on in ("rtl", "land", "hold")] == ["flight.rtl", "flight.land", "flight.hold"]
    assert stop_tool("rtl", "hold") == "flight.rtl"  # an explicit stop is what it says, whatever on_abort is
    made: list[str] = []
    for command in ("land", "rtl", "abort"):
        carry_out(command, "rtl", DOWN, lambda name, args: made.append(name), lambda *a, **k: None)
    assert made == []  # asked of an aircraft on the ground, disarmed: nothing to send (PX4 would deny it)


@pytest.mark.parametrize(("on_abort", "noted"), [("rtl", True), ("land", True), ("hold", False)])
def test_a_stop_that_takes_the_aircraft_away_says_where_it_was(on_abort: Any, noted: bool) -> None:
    flying = {"lat_deg": AWAY["lat"], "lon_deg": AWAY["lon"], "alt_m": 15.83, "landed_state": "in_air", "armed": True}
    made: list[str] = []
    said: list[dict[str, Any]] = []
    carry_out("abort", on_abort, flying, lambda n, a: made.append(n), lambda *a, **k: said.append(k))
    assert made == [f"flight.{on_abort}"]
    assert [k["stopped_at"] for k in said if "stopped_at" in k] == ([{**AWAY, "landed": False}] if noted else [])


@pytest.mark.parametrize(
    ("command", "on_abort"), [("abort", "rtl"), ("rtl", "hold"), ("abort", "land"), ("land", "rtl")]
)
def test_a_stop_on_the_ground_armed_lands_in_place_and_never_takes_off(command: str, on_abort: Any) -> None:
    """Just landed beside a casualty, or spinning up to take off: a return would need a take-off (PX4 denies it on
    the ground); the aircraft lands where it is, which disarms it, and it has not moved, so there is nowhere to go
    back to."""
    landed = {"lat_deg": AWAY["lat"], "lon_deg": AWAY["lon"], "alt_m": 0.0, "landed_state": "on_ground", "armed": True}
    made: Calls = []
    said: list[dict[str, Any]] = []
    carry_out(command, on_abort, landed, lambda n, a: made.append((n, a)), lambda *a, **k: said.append(k))
    assert made == [("flight.land", {})]
    assert [k for k in said if "stopped_at" in k] == []
    assert [k["summary"] for k in said] == [
        f"{command}: the aircraft is on the ground, armed: landing in place (it disarms), not taking off"
    ]


def test_a_hold_on_the_ground_armed_is_a_hold() -> None:
    landed = {"lat_deg": AWAY["lat"], "lon_deg": AWAY["lon"], "alt_m": 0.0, "landed_state": "on_ground", "armed": True}
    made: list[str] = []
    carry_out("abort", "hold", landed, lambda n, a: made.append(n), lambda *a, **k: None)
    assert made == ["flight.hold"]


def test_touching_down_is_not_on_the_ground_yet_a_return_goes_and_says_where_from() -> None:
    low = {"lat_deg": AWAY["lat"], "lon_deg": AWAY["lon"], "alt_m": 0.3, "landed_state": "landing", "armed": True}
    made: list[str] = []
    said: list[dict[str, Any]] = []
    carry_out("abort", "rtl", low, lambda n, a: made.append(n), lambda *a, **k: said.append(k))
    assert made == ["flight.rtl"]
    assert [k["stopped_at"] for k in said if "stopped_at" in k] == [{**AWAY, "alt_m": 0.3, "landed": True}]


def test_spinning_up_to_take_off_is_still_on_the_ground() -> None:
    spinning = {"lat_deg": AWAY["lat"], "lon_deg": AWAY["lon"], "alt_m": 0.2, "landed_state": "takeoff", "armed": True}
    made: list[str] = []
    carry_out("abort", "rtl", spinning, lambda n, a: made.append(n), lambda *a, **k: None)
    assert made == ["flight.land"]
    made.clear()
    carry_out("abort", "rtl", {**spinning, "alt_m": 3.0}, lambda n, a: made.append(n), lambda *a, **k: None)
    assert made == ["flight.rtl"]  # clear of the ground: a return flies home from there


@pytest.mark.parametrize(
    ("alt_m", "armed", "landed_state", "said"),
    [
        (-0.0, True, "landing", "on the ground, armed"),  # a landing asked for on the ground, before it disarms
        (0.2, True, "takeoff", "on the ground, armed"),  # spinning up
        (0.0, False, "unknown", "on the ground, disarmed"),
        (0.0, True, "on_ground", "on the ground, armed"),
        (0.3, True, "in_air", "in the air at 0.3 m"),  # a hover a hand's breadth up is still flying
        (3.0, True, "landing", "in the air at 3.0 m"),
        (3.0, True, "takeoff", "in the air at 3.0 m"),
    ],
)
def test_where_it_ended_says_on_the_ground_only_when_it_is(
    alt_m: float, armed: bool, landed_state: Any, said: str
) -> None:
    sample = TelemetrySample(time_s=9.0, lat_deg=AWAY["lat"], lon_deg=AWAY["lon"], alt_m=alt_m, north_m=30.0,
                             east_m=40.0, down_m=-alt_m, armed=armed, landed_state=landed_state)  # fmt: skip
    assert where_it_ended(sample).startswith(f"{said}, 50.0 m from home")
