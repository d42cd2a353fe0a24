"""Dormant tracks: a person seen motionless, then out of sight for minutes (the drone was stopped and came back),
takes back their id and stillness clock when seen at the same spot again; meanwhile they are listed nowhere. A walker
gets no such memory, and someone else standing elsewhere does not take the id."""

from __future__ import annotations

import numpy as np

from agentic_core.perception.measurement import Measurements
from agentic_core.perception.tracker import Tracker, TrackTable

R = np.eye(2) * 0.01
VIEW_HERE = np.array([[-20.0, -20.0], [20.0, -20.0], [20.0, 20.0], [-20.0, 20.0]])
VIEW_AWAY = VIEW_HERE + np.array([500.0, 0.0])  # the camera looks elsewhere: nobody here is in sight


def seen(*points: tuple[float, float]) -> Measurements:
    n = len(points)
    return Measurements(
        z=np.array(points, float).reshape(n, 2), R=np.repeat(R[None], n, axis=0), classes=["person"] * n,
        conf=np.full(n, 0.9), boxes=np.zeros((n, 4)), index=np.arange(n),
    )  # fmt: skip


def watch(tracker: Tracker, t0: float, seconds: float, m: Measurements, view: np.ndarray) -> TrackTable:
    table = tracker.step(t0, m, view)
    for k in range(1, int(seconds * 10) + 1):
        table = tracker.step(t0 + k / 10, m, view)
    return table


def test_a_motionless_person_out_of_sight_for_minutes_is_the_same_person_when_seen_there_again() -> None:
    tracker = Tracker()
    first = watch(tracker, 0.0, 5.0, seen((3.0, 4.0)), VIEW_HERE)
    (pid,) = first.ids
    away = watch(tracker, 5.1, 120.0, seen(), VIEW_AWAY)
    assert away.ids == []  # dormant: listed nowhere while out of sight
    back = watch(tracker, 125.2, 0.5, seen((3.02, 3.99)), VIEW_HERE)
    assert back.ids == [pid]
    assert back.state_names() == ["confirmed"]
    assert back.stationary_s[0] > 120.0  # found where they were: their stillness clock goes on


def test_a_walker_out_of_sight_gets_a_new_id() -> None:
    tracker = Tracker()
    table = tracker.step(0.0, seen((0.0, 0.0)), VIEW_HERE)
    for k in range(1, 50):
        table = tracker.step(k / 10, seen((0.12 * k, 0.0)), VIEW_HERE)  # walking at 1.2 m/s
    (walker,) = table.ids
    watch(tracker, 5.0, 60.0, seen(), VIEW_AWAY)
    back = watch(tracker, 65.1, 0.5, seen((5.9, 0.0)), VIEW_HERE)
    assert back.ids and walker not in back.ids


def test_someone_else_elsewhere_does_not_take_a_dormant_id() -> None:
    tracker = Tracker()
    (pid,) = watch(tracker, 0.0, 5.0, seen((3.0, 4.0)), VIEW_HERE).ids
    watch(tracker, 5.1, 60.0, seen(), VIEW_AWAY)
    other = watch(tracker, 65.2, 0.5, seen((6.0, 4.0)), VIEW_HERE)  # 3 m from where the first one lay
    assert other.ids and pid not in other.ids
    assert other.stationary_s[0] < 1.0


def test_a_dormant_track_is_forgotten_after_its_window() -> None:
    tracker = Tracker()
    (pid,) = watch(tracker, 0.0, 5.0, seen((3.0, 4.0)), VIEW_HERE).ids
    window = tracker.config.dormant_window_s
    tracker.step(5.0 + window + 1.0, seen(), VIEW_AWAY)
    assert len(tracker) == 0  # nothing kept past the window: memory stays bounded
    back = watch(tracker, 6.0 + window, 0.5, seen((3.0, 4.0)), VIEW_HERE)
    assert back.ids and pid not in back.ids
