"""Gate (tier 2): asked once per (trigger, object) and remembered; only high or critical acts; ``trigger`` and
``decision`` events; a lost track looked at again for a bounded time; a re-identified object judged under its new
id; the reasoner's call paced at real time."""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest

from agentic_core.agent import ACT_AT, Gate, Pace, acts
from agentic_core.perception.world_model import WorldModel

from .fakes import (
    Events,
    FakeReasoner,
    FakeVehicle,
    FakeWorld,
    Unsure,
    decision,
    eventually,
    person,
    wait_for,
    world_of,
)
from .missions import trigger

pytestmark = pytest.mark.timeout(60)


def gate_for(
    reasoner: FakeReasoner,
    world: FakeWorld | None = None,
    vehicle: FakeVehicle | None = None,
    pace: Pace | None = None,
    **options: Any,
) -> tuple[Gate, Events]:
    events = Events()
    made = Gate(
        reasoner, world or FakeWorld(world_of(person("P-1"), person("P-2"))), vehicle or FakeVehicle(),
        events.publish, pace or Pace(None), **options,
    )  # fmt: skip
    return made, events


def looked(events: Events) -> list[str | None]:
    return [s for s in events.summaries("log") if s and s.startswith("looked again")]


def test_asks_the_reasoner_once_per_trigger_and_object_and_remembers() -> None:
    reasoner = FakeReasoner("critical")
    gate, events = gate_for(reasoner)
    fallen, again = trigger("fallen"), trigger("again")
    p1 = {"id": "P-1", "stationary_s": 5.0}
    assert not gate.known("fallen", p1)
    assert gate(fallen, p1) and gate(fallen, {"id": "P-1", "stationary_s": 99.0})  # same object, moved on
    assert reasoner.foci() == ["P-1"] and gate.known("fallen", p1) and not gate.known("again", p1)
    assert gate(again, p1) and gate(fallen, {"id": "P-2"})
    assert reasoner.foci() == ["P-1", "P-1", "P-2"] and gate.decisions == 3
    assessment = gate.assessment("fallen", p1)
    assert assessment is not None and assessment.severity == "critical" and assessment.subject_id == "P-1"
    assert len(events.of("trigger")) == 3  # one trigger event per question, none for a remembered verdict


@pytest.mark.parametrize("severity", ["none", "low", "high", "critical", None])
def test_only_high_or_critical_acts_and_a_failed_assessment_does_not(severity: str | None) -> None:
    reasoner = FakeReasoner(severity)
    gate, events = gate_for(reasoner)
    act = gate(trigger(), {"id": "P-1"})
    assert act is (severity in ("high", "critical")) and acts(decision(severity).assessment) is act
    assert gate(trigger(), {"id": "P-1"}) is act and len(reasoner.calls) == 1  # a no is remembered as well as a yes
    [fired] = events.of("trigger")
    assert fired["trigger"] == "fallen" and fired["event"] == "P-1" and fired["act"] is act
    assert fired["summary"] == f"fallen on P-1: {'act' if act else 'no action'}"
    [said] = events.of("decision")
    assert said["why"] == "trigger fallen" and said["focus"] == "P-1" and said["reasoner"] == "fake"
    verdict = severity if severity is not None else "failed (the model did not answer)"
    assert said["summary"] == f"fake on P-1: {verdict}"
    assert ACT_AT == ("high", "critical") and not acts(None)


def test_the_decision_is_published_before_the_trigger_and_remembered_as_the_last() -> None:
    seen: list[tuple[WorldModel, Any]] = []
    reasoner = FakeReasoner("high")
    gate, events = gate_for(reasoner, on_decision=lambda world, d: seen.append((world, d)))
    gate(trigger(), {"id": "P-2"})
    assert [e.kind for e in events.events] == ["decision", "trigger"]
    assert gate.last is not None and gate.last is seen[0][1] and seen[0][0] is reasoner.calls[0][1]


def test_an_event_that_is_not_an_object_is_judged_on_the_scene_once() -> None:
    reasoner = FakeReasoner("critical")
    gate, events = gate_for(reasoner)
    assert gate(trigger(), True) and gate(trigger(), 3)  # a rule that returned a truth value, or a count
    assert reasoner.foci() == [None] and events.of("trigger")[0]["event"] is None


def test_two_threads_asking_about_the_same_object_ask_the_reasoner_once() -> None:
    release = threading.Event()

    def hold(focus: str | None) -> None:
        release.wait(10)

    reasoner = FakeReasoner("critical", during=hold)
    gate, _ = gate_for(reasoner)
    answers: list[bool] = []
    workers = [threading.Thread(target=lambda: answers.append(gate(trigger(), {"id": "P-1"}))) for _ in range(2)]
    for worker in workers:
        worker.start()
    wait_for(lambda: len(reasoner.calls) >= 1, what="the reasoner to be asked")
    eventually(lambda: len(reasoner.calls) == 2, timeout_s=1.0)  # the second caller's chance to ask again
    release.set()
    for worker in workers:
        worker.join(10)
    assert answers == [True, True] and len(reasoner.calls) == 1


# ---- looking again at a track lost just now (the intent of the former tests/agentic_core/run/test_look_again.py)


@pytest.mark.parametrize("seen_again", [True, False])
def test_a_lost_track_is_looked_at_again_for_a_bounded_time(seen_again: bool) -> None:
    world = FakeWorld(world_of(person("P-3", "lost")))
    # seen again: plenty of time to be seen in; not seen: the vehicle's clock moves on while the gate looks
    vehicle = FakeVehicle(step_s=0.0 if seen_again else 0.01)
    reasoner = FakeReasoner("critical")
    gate, events = gate_for(reasoner, world, vehicle, look_again_s=5.0 if seen_again else 0.3)
    if seen_again:
        reads = world.reads

        def comes_back() -> None:
            wait_for(lambda: world.reads > reads + 3, what="the gate to look")
            world.set(world_of(person("P-3", "confirmed")))

        threading.Thread(target=comes_back, daemon=True).start()
    start = vehicle.clock()
    assert gate(trigger(), {"id": "P-3"})
    [(focus, judged)] = reasoner.calls
    found = judged.get("P-3")
    assert focus == "P-3" and found is not None and found.state == ("confirmed" if seen_again else "lost")
    assert looked(events) == [f"looked again at P-3: {'seen' if seen_again else 'still not seen'}"]
    if not seen_again:
        assert vehicle.clock() - start >= 0.3  # it looked for the whole of look_again_s of the vehicle's clock


def test_looking_again_is_bounded_in_wall_time_when_the_vehicle_clock_stands_still() -> None:
    world = FakeWorld(world_of(person("P-3", "lost")))
    gate, events = gate_for(FakeReasoner("none"), world, FakeVehicle(step_s=0.0), look_again_s=0.2)
    started = time.monotonic()
    assert not gate(trigger(), {"id": "P-3"})
    assert 0.2 <= time.monotonic() - started < 1.2 + 2.0  # look_again_s, plus at most a second (and slack)
    assert looked(events) == ["looked again at P-3: still not seen"]


def test_while_looking_again_the_simulation_may_run_at_its_setting() -> None:
    pace = Pace(None)
    speeds: list[float | None] = []
    world = FakeWorld(world_of(person("P-3", "lost")))
    world.on_read = lambda: speeds.append(pace.speed())
    gate, _ = gate_for(FakeReasoner("none"), world, FakeVehicle(step_s=0.01), pace=pace, look_again_s=0.1)
    gate(trigger(), {"id": "P-3"})
    assert None in speeds  # frames awaited from the vehicle: full speed
    assert pace.speed() == 1.0


@pytest.mark.parametrize("focus", ["P-3", "P-99"])
def test_a_track_in_view_or_unknown_is_judged_at_once(focus: str) -> None:
    now = world_of(person("P-3", "confirmed"))
    world = FakeWorld(now)
    reasoner = FakeReasoner("critical")
    gate, events = gate_for(reasoner, world, FakeVehicle(step_s=0.0), look_again_s=30.0)
    started = time.monotonic()
    gate(trigger(), {"id": focus})
    assert time.monotonic() - started < 5 and looked(events) == []
    assert reasoner.calls[0][1] is now


def test_a_dropped_track_is_judged_under_its_new_id_and_the_log_names_both() -> None:
    world = FakeWorld(world_of(person("P-7", "confirmed")), renamed={"P-3": "P-7"})
    reasoner = FakeReasoner("critical")
    gate, events = gate_for(reasoner, world)
    assert gate(trigger(), {"id": "P-3"})
    assert reasoner.foci() == ["P-7"]
    [log] = events.of("log")
    assert log["focus"] == "P-3" and log["now"] == "P-7" and "P-3" in log["summary"] and "P-7" in log["summary"]
    assert events.of("decision")[0]["focus"] == "P-7" and gate.known("fallen", {"id": "P-3"})


def test_a_re_identified_track_that_is_lost_is_looked_at_again_under_its_new_id() -> None:
    world = FakeWorld(world_of(person("P-7", "lost")), renamed={"P-3": "P-7"})
    gate, events = gate_for(FakeReasoner("low"), world, FakeVehicle(step_s=0.01), look_again_s=0.1)
    gate(trigger(), {"id": "P-3"})
    assert looked(events) == ["looked again at P-7: still not seen"]


def test_an_object_that_resolves_to_nothing_or_itself_logs_no_re_identification() -> None:
    gate, events = gate_for(FakeReasoner("low"), FakeWorld(world_of(person("P-1"))))
    gate(trigger(), {"id": "P-1"})
    gate(trigger(), {"id": "P-404"})
    assert events.of("log") == []


@pytest.mark.parametrize("setting", [None, 20.0])
def test_the_reasoner_thinks_at_real_time_even_while_a_flight_action_flies(setting: float | None) -> None:
    pace = Pace(setting)
    inside: list[float | None] = []
    reasoner = FakeReasoner("critical", during=lambda focus: inside.append(pace.speed()))
    gate, _ = gate_for(reasoner, pace=pace)
    with pace.waiting("vehicle"):  # a fly_to under way on another of the agent's threads
        gate(trigger(), {"id": "P-1"})
        gate.decide(None, "analyze_scene")
        assert pace.speed() == setting
    assert inside == [1.0, 1.0]


def test_a_reasoner_that_raises_leaves_the_pace_as_it_was() -> None:
    pace = Pace(None)

    def boom(focus: str | None) -> None:
        raise RuntimeError("model crashed")

    gate, _ = gate_for(FakeReasoner("critical", during=boom), pace=pace)
    with pace.waiting("vehicle"):
        with pytest.raises(RuntimeError):
            gate.decide("P-1", "analyze_scene")
        assert pace.speed() is None


# ---- a confirmation that must be sure (analyze_scene's min_confidence) looks again before it fails


def casualty_at(conf: float = 0.4) -> WorldModel:
    """The casualty as the frames show it: at ``conf``."""
    return world_of({**person("P-1"), "conf": conf})


def unsure_gate(
    confidences: list[float], persons: int = 1, step_s: float = 0.01, world: FakeWorld | None = None
) -> tuple[Gate, Unsure, Events]:
    vehicle, pace = FakeVehicle(step_s=step_s), Pace(None)
    reasoner, events = Unsure(confidences, vehicle, persons), Events()
    gate = Gate(reasoner, world or FakeWorld(casualty_at()), vehicle, events.publish, pace, look_again_s=0.2)
    return gate, reasoner, events


def test_looking_again_ends_at_the_first_frame_that_is_sure_enough() -> None:
    """The drone hovers over the casualty until a frame shows it as sure as asked, up to ``look_again_s``, and is
    judged then: a confirmation is not failed, nor held the whole look, for a frame or two of doubt."""
    world = FakeWorld(casualty_at())
    gate, reasoner, _ = unsure_gate([0.42, 0.81], world=world)
    reads = 0

    def sure_after_a_few_frames() -> None:
        nonlocal reads
        reads += 1
        if reads == 5:
            world.set(casualty_at(0.8))

    world.on_read = sure_after_a_few_frames
    decided = gate.confident("P-1", "analyze_scene", 0.5)
    first, second = reasoner.at
    assert decided.assessment is not None and decided.assessment.confidence == 0.81
    assert first is not None and second is not None and second - first < 0.2  # judged before the look ran out


def test_an_unsure_confirmation_is_looked_at_again_and_judged_once_more() -> None:
    gate, reasoner, events = unsure_gate([0.42, 0.81])
    decided = gate.confident("P-1", "analyze_scene", 0.5)
    assert decided.assessment is not None and decided.assessment.confidence == 0.81 and gate.last is decided
    first, second = reasoner.at
    assert first is not None and second is not None and second - first >= 0.2  # new frames between the two looks
    assert [d["why"] for d in events.of("decision")] == ["analyze_scene", "analyze_scene, looked again"]
    assert events.summaries("log") == ["confidence 0.42 is under the 0.50 asked for: looking again for 0.2 s"]
    kinds = [e.kind for e in events.events]
    assert kinds == ["decision", "log", "decision"]  # the trace says why it was asked twice, in order


def test_still_unsure_after_looking_again_it_gives_the_second_verdict_and_asks_no_third_time() -> None:
    gate, reasoner, _ = unsure_gate([0.42, 0.3, 0.99])
    decided = gate.confident("P-1", "analyze_scene", 0.5)
    assert decided.assessment is not None and decided.assessment.confidence == 0.3 and len(reasoner.at) == 2


@pytest.mark.parametrize(
    ("confidences", "persons", "floor"),
    [([0.5], 1, 0.5), ([0.0], 0, 0.5), ([0.1], 1, 0.0), ([0.97], 3, 0.95)],
    ids=["exactly-the-floor", "nobody-seen", "no-floor", "above-the-floor"],
)
def test_a_sure_enough_answer_is_taken_at_once(confidences: list[float], persons: int, floor: float) -> None:
    gate, reasoner, events = unsure_gate(confidences, persons)
    started = time.monotonic()
    gate.confident("P-1", "analyze_scene", floor)
    assert len(reasoner.at) == 1 and events.of("log") == [] and time.monotonic() - started < 0.2


def test_a_failed_reasoner_is_not_asked_again_by_the_confirmation() -> None:
    reasoner = FakeReasoner(None)
    gate, events = gate_for(reasoner, look_again_s=5.0)
    decided = gate.confident("P-1", "analyze_scene", 0.5)
    assert decided.assessment is None and len(reasoner.calls) == 1 and events.of("log") == []


def test_looking_again_at_an_unsure_answer_runs_the_simulation_and_is_bounded_in_wall_time() -> None:
    gate, reasoner, _ = unsure_gate([0.2], step_s=0.0)  # the vehicle's clock stands still: only the wall bound ends it
    speeds: list[float | None] = []
    started = time.monotonic()
    watching = threading.Thread(target=lambda: gate.confident("P-1", "analyze_scene", 0.5))
    watching.start()
    wait_for(lambda: len(reasoner.at) == 1, what="the first look")

    def full_speed() -> bool:
        speeds.append(gate.pace.speed())
        return speeds[-1] is None

    wait_for(full_speed, what="the simulation at full speed while it looks again")
    watching.join(10)
    assert not watching.is_alive() and len(reasoner.at) == 2 and gate.pace.speed() == 1.0
    assert 0.2 <= time.monotonic() - started < 1.2 + 2.0  # look_again_s, plus at most a second (and slack)
