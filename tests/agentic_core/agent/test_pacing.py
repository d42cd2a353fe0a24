"""Pace: the simulation runs at its setting only while nothing but the vehicle is awaited, at real time at most
otherwise — with nested waits, waits on several threads, and waits left by an exception."""

from __future__ import annotations

import threading

import pytest

from agentic_core.agent import Pace
from agentic_core.agent.pacing import WaitKind

pytestmark = pytest.mark.timeout(60)

OTHERS: list[WaitKind] = ["model", "tool", "operator"]
SETTINGS = [None, 0.5, 1.0, 8.0]


def real_time_at_most(setting: float | None) -> float:
    return 1.0 if setting is None else min(setting, 1.0)


@pytest.mark.parametrize("setting", SETTINGS)
def test_idle_runs_at_real_time_at_most(setting: float | None) -> None:
    assert Pace(setting).speed() == real_time_at_most(setting)


@pytest.mark.parametrize("setting", SETTINGS)
def test_a_vehicle_only_wait_runs_at_the_setting(setting: float | None) -> None:
    pace = Pace(setting)
    with pace.waiting("vehicle"), pace.waiting("vehicle"):
        assert pace.speed() == setting
    assert pace.speed() == real_time_at_most(setting)


@pytest.mark.parametrize("setting", SETTINGS)
@pytest.mark.parametrize("other", OTHERS)
def test_any_other_wait_runs_at_real_time_at_most_nested_either_way(setting: float | None, other: WaitKind) -> None:
    pace = Pace(setting)
    with pace.waiting("vehicle"):
        with pace.waiting(other):
            assert pace.speed() == real_time_at_most(setting)
        assert pace.speed() == setting
    with pace.waiting(other), pace.waiting("vehicle"):
        assert pace.speed() == real_time_at_most(setting)
    assert pace.speed() == real_time_at_most(setting)


def test_concurrent_waits_from_threads_count_together() -> None:
    pace = Pace(None)
    flying, thinking = threading.Event(), threading.Event()
    release_vehicle, release_model = threading.Event(), threading.Event()

    def wait(kind: WaitKind, entered: threading.Event, release: threading.Event) -> None:
        with pace.waiting(kind):
            entered.set()
            release.wait(10)

    vehicle = threading.Thread(target=wait, args=("vehicle", flying, release_vehicle))
    model = threading.Thread(target=wait, args=("model", thinking, release_model))
    vehicle.start()
    assert flying.wait(5) and pace.speed() is None
    model.start()
    assert thinking.wait(5) and pace.speed() == 1.0  # another thread's model call slows the flight
    release_model.set()
    model.join(5)
    assert pace.speed() is None
    release_vehicle.set()
    vehicle.join(5)
    assert pace.speed() == 1.0


def test_many_threads_entering_and_leaving_leave_the_counters_at_zero() -> None:
    pace = Pace(4.0)
    barrier = threading.Barrier(8, timeout=10)

    def churn(index: int) -> None:
        barrier.wait()
        kind: WaitKind = "vehicle" if index % 2 else OTHERS[index % 3]
        for _ in range(500):
            with pace.waiting(kind):
                pass

    workers = [threading.Thread(target=churn, args=(i,)) for i in range(8)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(30)
    assert pace.speed() == 1.0
    with pace.waiting("vehicle"):
        assert pace.speed() == 4.0  # no stray "other" wait left behind


@pytest.mark.parametrize("kind", ["vehicle", *OTHERS])
def test_counters_go_back_to_zero_after_an_exception_in_the_block(kind: WaitKind) -> None:
    pace = Pace(None)
    with pytest.raises(RuntimeError), pace.waiting("vehicle"), pace.waiting(kind):
        raise RuntimeError("the call failed")
    assert pace.speed() == 1.0
    with pace.waiting("vehicle"):
        assert pace.speed() is None  # neither a vehicle nor an other wait was left counted
    with pytest.raises(KeyboardInterrupt), pace.waiting(kind):
        raise KeyboardInterrupt
    with pace.waiting("vehicle"):
        assert pace.speed() is None


def test_the_setting_may_change_during_a_run() -> None:
    pace = Pace(None)
    with pace.waiting("vehicle"):
        pace.setting = 3.0
        assert pace.speed() == 3.0
        pace.setting = 0.25
        assert pace.speed() == 0.25
        with pace.waiting("tool"):
            assert pace.speed() == 0.25  # slower than real time stays slower


def test_urgent_slows_the_simulation_whatever_is_awaited_until_cleared() -> None:
    from agentic_core.agent.pacing import URGENT_SPEED

    pace = Pace(None)
    with pace.waiting("vehicle"):
        assert pace.speed() is None
        pace.urgent(True)
        assert pace.speed() == URGENT_SPEED < 1.0
        with pace.waiting("model"):
            assert pace.speed() == URGENT_SPEED
        pace.urgent(False)
        assert pace.speed() is None
