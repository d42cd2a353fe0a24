"""TelemetryFailsafes: battery, wind, GPS, flight time and link, each on telemetry alone, each once, in the air
only; the mission chooses what they do; the vehicle's own failsafe texts are reported, injected faults' are not."""

from __future__ import annotations

import threading
from typing import Any

import pytest

from agentic_core.agent.control import ControlPort
from agentic_core.agent.failsafes import POLL_S, TelemetryFailsafes
from agentic_core.contracts import TelemetrySample
from agentic_core.contracts.policy_graph import Limits

FLYING = dict(lat_deg=21.4, lon_deg=39.9, alt_m=12.0, north_m=5, east_m=5, down_m=-12, armed=True,
              landed_state="in_air", battery_pct=90.0, gps_fix_type=3, gps_satellites=12)  # fmt: skip


def sample(t: float = 10.0, **changes: Any) -> TelemetrySample:
    return TelemetrySample(**{**FLYING, "time_s": t, **changes})


class Said:
    def __init__(self) -> None:
        self.events: list[tuple[str, dict[str, Any]]] = []

    def __call__(self, kind: str, /, **fields: Any) -> None:
        self.events.append((kind, fields))

    def failsafes(self) -> list[dict[str, Any]]:
        return [f for k, f in self.events if k == "failsafe"]


def watch(limits: Limits, **kw: Any) -> tuple[TelemetryFailsafes, ControlPort, Said]:
    port, said = ControlPort(), Said()
    return TelemetryFailsafes(limits, port, said, **kw), port, said


@pytest.mark.parametrize(
    ("limits", "bad", "kind", "stop"),
    [
        (Limits(min_battery_pct=25), {"battery_pct": 24.9}, "battery", "rtl"),
        (Limits(max_wind_mps=8), {"wind_north_mps": 6.0, "wind_east_mps": 6.0}, "wind", "rtl"),
        (Limits(), {"gps_fix_type": 1, "gps_satellites": 3}, "gps", "land"),  # a return needs a position
        (Limits(failsafe_actions={"gps": "hold"}), {"gps_fix_type": 0}, "gps", "hold"),
        (Limits(min_battery_pct=25, failsafe_action="land"), {"battery_pct": 10.0}, "battery", "land"),
        (Limits(max_wind_mps=5, failsafe_action="hold"), {"wind_north_mps": -5.5, "wind_east_mps": 0.0}, "wind",
         "hold"),
    ],
)  # fmt: skip
def test_each_failsafe_fires_once_in_the_air_with_the_mission_action(limits, bad, kind, stop) -> None:
    fs, port, said = watch(limits)
    fs(sample())
    assert port.stop_requested() is None and said.events == []  # healthy: nothing
    fs(sample(**bad, armed=False, landed_state="on_ground"))
    assert port.stop_requested() is None  # on the ground: nothing
    for t in (11.0, 12.0, 13.0):
        fs(sample(t, **bad))
    (event,) = said.failsafes()
    assert event["failsafe"] == kind and event["action"] == stop and event["by"] == "agent" and event["acted"]
    assert port.stop_requested() == stop and port.stopped_by == "failsafe"
    assert fs.fired == [kind]


def test_within_the_limits_exactly_nothing_fires() -> None:
    fs, port, said = watch(Limits(min_battery_pct=25, max_wind_mps=8, max_flight_time_s=60))
    fs(sample(0.0))
    fs(sample(60.0, battery_pct=25.0, wind_north_mps=8.0, wind_east_mps=0.0, gps_fix_type=3))
    fs(sample(60.0, battery_pct=None, wind_north_mps=None, gps_fix_type=None))  # not reported: not judged
    assert said.events == [] and port.stop_requested() is None


def test_the_flight_time_counts_from_take_off_on_the_vehicle_clock() -> None:
    fs, port, said = watch(Limits(max_flight_time_s=30))
    fs(sample(100.0, armed=False, landed_state="on_ground"))  # waiting on the ground does not count
    fs(sample(120.0))
    fs(sample(150.0))
    assert port.stop_requested() is None
    fs(sample(150.5))
    (event,) = said.failsafes()
    assert event["failsafe"] == "flight_time" and port.stop_requested() == "rtl"
    assert "30 s" in event["summary"]


def test_a_second_failsafe_is_recorded_but_the_first_stop_stands() -> None:
    fs, port, said = watch(Limits(min_battery_pct=25))
    fs(sample(battery_pct=20.0))
    fs(sample(11.0, battery_pct=20.0, gps_fix_type=0))
    first, second = said.failsafes()
    assert first["failsafe"] == "battery" and second["failsafe"] == "gps"
    assert second["acted"] is False and "already stopping (rtl)" in second["summary"]
    assert port.stop_requested() == "rtl" and fs.fired == ["battery", "gps"]


def test_samples_from_many_threads_fire_a_failsafe_once() -> None:
    fs, port, said = watch(Limits(min_battery_pct=25))
    go = threading.Barrier(8)

    def hammer() -> None:
        go.wait()
        for i in range(50):
            fs(sample(10.0 + i, battery_pct=5.0))

    threads = [threading.Thread(target=hammer) for _ in range(8)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert len(said.failsafes()) == 1 and port.stop_requested() == "rtl"


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def test_a_silent_link_in_the_air_fires_the_link_failsafe_after_link_loss_s() -> None:
    clock = Clock()
    fs, port, said = watch(Limits(link_loss_s=5), wall=clock)
    fs.check()
    assert said.events == []  # nothing heard yet: no link to lose
    fs(sample())
    clock.now += 5.0
    fs.check()
    assert said.events == []
    clock.now += 0.5
    fs.check()
    fs.check()
    (event,) = said.failsafes()
    assert event["failsafe"] == "link" and event["silent_s"] == 5.5 and port.stop_requested() == "rtl"


def test_a_silent_link_on_the_ground_is_no_failsafe() -> None:
    clock = Clock()
    fs, port, said = watch(Limits(link_loss_s=5), wall=clock)
    fs(sample(armed=False, landed_state="on_ground"))
    clock.now += 60.0
    fs.check()
    assert said.events == [] and port.stop_requested() is None


def test_the_vehicle_own_failsafe_texts_are_reported_and_fault_texts_are_not() -> None:
    heard = [
        "Failure injected: GPS off",
        "GPS lost, no position: landing",
        "Battery low (14%): returning",
        "Failsafe position: Landing denied",
        "Takeoff detected",
        "Geofence breached (205 m from home): holding",
        "Failsafe activated: Autoland",  # PX4's wording
    ]
    batches = [heard[:3], [], heard[3:]]
    fs, port, said = watch(Limits(), texts=lambda: batches.pop(0) if batches else [])
    for _ in range(4):
        fs.check()
    reported = [f["text"] for f in said.failsafes()]
    assert reported == [heard[1], heard[2], heard[5], heard[6]]
    assert all(f["by"] == "vehicle" for f in said.failsafes())
    assert port.stop_requested() is None  # the vehicle acts itself; the agent only records it


def test_the_watch_thread_checks_until_closed() -> None:
    clock = Clock()
    fs, port, said = watch(Limits(link_loss_s=1), wall=clock)
    fs(sample())
    clock.now += 2.0
    fs.start()
    stopped = threading.Event()
    port.on_question(lambda q: None)
    for _ in range(int(10 / POLL_S)):
        if port.stop_requested() is not None:
            stopped.set()
            break
        port.wait_for_change(POLL_S)
    fs.close()
    fs.close()  # twice is fine
    assert stopped.is_set() and [f["failsafe"] for f in said.failsafes()] == ["link"]
    assert not [t for t in threading.enumerate() if t.name == "failsafe-watch"]
