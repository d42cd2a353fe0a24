"""Deconfliction: whatever legs the swarm asks for, in whatever order, the legs the airspace grants never come
closer than the configured separation (checked by sampling, independently of the planner's closed form)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agentic_core.contracts.swarm import Point
from agentic_core.swarm.deconflict import Airspace, NoSafeLeg, Trajectory, conflict, min_separation

H, V = 15.0, 8.0


def _track(trajectory: Trajectory, times: np.ndarray) -> np.ndarray:
    """Positions (north, east, alt) at ``times``, interpolated by numpy: an implementation apart from ``at``."""
    ts = [t for t, _ in trajectory.waypoints]
    columns = [[getattr(p, axis) for _, p in trajectory.waypoints] for axis in ("north", "east", "alt")]
    return np.stack([np.interp(times, ts, column) for column in columns], axis=1)


def _violates(a: Trajectory, b: Trajectory, step_s: float = 0.05) -> float | None:
    """The first sampled time (every ``step_s`` and at every breakpoint) where both distances are under the limits."""
    lo, hi = max(a.start, b.start), min(a.until, b.until)
    if lo > hi:
        return None
    breaks = [t for t in a.breakpoints() + b.breakpoints() if lo <= t <= hi]
    times = np.unique(np.concatenate([np.arange(lo, hi, step_s), [lo, hi], breaks]))
    pa, pb = _track(a, times), _track(b, times)
    horizontal = np.hypot(pa[:, 0] - pb[:, 0], pa[:, 1] - pb[:, 1])
    lost = (horizontal < H - 1e-6) & (np.abs(pa[:, 2] - pb[:, 2]) < V - 1e-6)
    return float(times[np.argmax(lost)]) if lost.any() else None


def test_head_on_in_one_layer_is_a_conflict_and_a_layer_apart_is_not() -> None:
    east = Trajectory("a", ((0.0, Point(north=0, east=0, alt=30)), (20.0, Point(north=0, east=200, alt=30))), 20.0)
    west = Trajectory("b", ((0.0, Point(north=0, east=200, alt=30)), (20.0, Point(north=0, east=0, alt=30))), 20.0)
    above = Trajectory("b", tuple((t, p.model_copy(update={"alt": 40.0})) for t, p in west.waypoints), 20.0)
    hit = conflict(east, west, H, V)
    assert hit is not None and 9.0 < hit < 10.0  # they meet at t=10 s, 15 m apart at 10 - 15/20 s
    assert conflict(east, above, H, V) is None and _violates(east, above) is None


def test_legs_that_cross_are_put_in_different_layers_or_later() -> None:
    airspace = Airspace(layers=(30.0,), horizontal_m=H, vertical_m=V, delay_step_s=5.0)
    a = airspace.reserve("a", Point(north=0, east=-100, alt=30), Point(north=0, east=100), t0=0.0)
    b = airspace.reserve("b", Point(north=-100, east=0, alt=30), Point(north=100, east=0), t0=0.0)
    assert b.waypoints[1][0] > 0.0  # one layer only: b waits
    assert conflict(a, b, H, V) is None and _violates(a, b) is None


def test_no_room_is_a_clear_error_not_a_conflict() -> None:
    airspace = Airspace(layers=(30.0,), horizontal_m=H, vertical_m=V, hold_s=1e6, max_delay_s=10.0)
    airspace.reserve("a", Point(north=0, east=0, alt=30), Point(north=0, east=0), t0=0.0)  # parks for good
    with pytest.raises(NoSafeLeg, match=r"b: no layer of \[30.0\]"):
        airspace.reserve("b", Point(north=0, east=-100, alt=30), Point(north=0, east=0), t0=0.0)


def test_a_landing_leg_comes_down_over_its_goal_and_a_hold_says_whom_it_clashes_with() -> None:
    airspace = Airspace(layers=(30.0,), horizontal_m=H, vertical_m=V, climb_mps=2.0, descent_mps=1.0, hold_s=50.0)
    airspace.prefer("a", 30.0)
    down = airspace.reserve("a", Point(north=0, east=0, alt=30), Point(north=80, east=0), t0=0.0, land=True)
    assert down.waypoints[-1][1] == Point(north=80, east=0, alt=0) and down.waypoints[-2][1].alt == 30.0
    assert down.waypoints[-1][0] - down.waypoints[-2][0] == pytest.approx(30.0)  # 30 m down at 1 m/s
    assert airspace.hold("b", Point(north=80, east=5, alt=5), t0=10.0) == ["a"]  # where a lands, strayed there
    assert airspace.hold("b", Point(north=0, east=300, alt=30), t0=11.0) == []
    assert airspace.release("a") == 1 and airspace.release("a") == 0 and "a" not in airspace.reserved
    with pytest.raises(ValueError):
        airspace.prefer("a", 35.0)  # not a layer


def test_the_minimum_separation_flown_is_measured() -> None:
    tracks = {
        "a": [(0.0, Point(north=0, east=0, alt=30)), (1.0, Point(north=0, east=10, alt=30))],
        "b": [(0.0, Point(north=0, east=50, alt=30)), (1.0, Point(north=0, east=30, alt=30))],
    }
    assert min_separation(tracks) == (20.0, "a", "b", 1.0)


coordinate = st.floats(min_value=-150, max_value=150, allow_nan=False)


@st.composite
def requests(draw: st.DrawFn) -> list[tuple[str, Point, float]]:
    n = draw(st.integers(2, 5))
    legs = [(f"u{i}", Point(north=draw(coordinate), east=draw(coordinate)), draw(st.floats(0, 30))) for i in range(n)]
    legs += draw(
        st.lists(
            st.tuples(
                st.sampled_from([f"u{i}" for i in range(n)]),
                st.builds(Point, north=coordinate, east=coordinate),
                st.floats(0, 30),
            ),
            max_size=6,
        )
    )
    return legs


@settings(max_examples=60, deadline=None)
@given(
    requests(),
    st.sampled_from([(30.0,), (30.0, 40.0), (30.0, 40.0, 50.0)]),
    st.lists(st.booleans(), min_size=11, max_size=11),
)
def test_granted_legs_never_lose_separation(
    legs: list[tuple[str, Point, float]], layers: tuple[float, ...], lands: list[bool]
) -> None:
    """Legs that land (come down over their goal) among them."""
    airspace = Airspace(layers=layers, horizontal_m=H, vertical_m=V, hold_s=20.0, delay_step_s=4.0, max_delay_s=80.0)
    where = {f"u{i}": Point(north=-400.0, east=40.0 * i, alt=0.0) for i in range(6)}  # a launch line, 40 m apart
    free_at = dict.fromkeys(where, 0.0)
    granted = 0
    for i, (uav, goal, wait) in enumerate(legs):
        try:
            leg = airspace.reserve(uav, where[uav], goal, t0=free_at[uav] + wait, land=lands[i % len(lands)])
        except NoSafeLeg:
            continue
        granted += 1
        where[uav], free_at[uav] = leg.waypoints[-1][1], leg.waypoints[-1][0]
    assert granted >= 1
    flat = [(u, t) for u, legs_of in airspace.reserved.items() for t in legs_of]
    for (ua, a), (ub, b) in itertools.combinations(flat, 2):
        if ua != ub:
            assert _violates(a, b) is None, (a, b)
