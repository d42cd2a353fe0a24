"""EventBus: gap-free ordered numbering under concurrent publishers, one order for every subscriber, broken
subscribers contained and recorded, unsubscribe."""

from __future__ import annotations

import threading

import pytest

from agentic_core.agent import EventBus
from agentic_core.contracts import RunEvent

from .fakes import Events

pytestmark = pytest.mark.timeout(60)

THREADS, EACH = 8, 250


def hammer(bus: EventBus) -> None:
    barrier = threading.Barrier(THREADS, timeout=10)

    def work(index: int) -> None:
        barrier.wait()
        for n in range(EACH):
            bus.publish("log", thread=index, n=n)

    workers = [threading.Thread(target=work, args=(i,)) for i in range(THREADS)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(30)
    assert not any(worker.is_alive() for worker in workers), "a publisher hung"


def test_seq_is_strictly_increasing_and_gap_free_under_eight_publishing_threads() -> None:
    bus = EventBus(first_seq=41)
    first, second = Events(), Events()
    bus.subscribe(first)
    bus.subscribe(second)
    hammer(bus)
    seqs = [e.seq for e in first.events]
    assert seqs == list(range(42, 42 + THREADS * EACH))
    assert bus.seq == 41 + THREADS * EACH
    # every subscriber saw the very same sequence (the same objects, in the same order)
    assert [id(e) for e in first.events] == [id(e) for e in second.events]
    # each publisher's own events kept their order
    for index in range(THREADS):
        assert [e.fields()["n"] for e in first.events if e.fields()["thread"] == index] == list(range(EACH))


def test_publish_returns_the_event_as_delivered_with_the_clock_stamped() -> None:
    ticks = iter([1.23456, 2.0])
    bus = EventBus(clock=lambda: next(ticks))
    seen = Events()
    bus.subscribe(seen)
    event = bus.publish("tool", name="flight.hold", summary="x")
    assert seen.events == [event] and event.sim_t == 1.235 and event.fields() == {"name": "flight.hold"}
    assert EventBus().publish("log").sim_t is None  # no clock: no simulated time


def test_a_raising_subscriber_breaks_neither_publish_nor_the_others_and_is_recorded() -> None:
    bus = EventBus()
    before, after = Events(), Events()

    def broken(event: RunEvent) -> None:
        if event.seq % 2:
            raise RuntimeError(f"broken on {event.seq}")

    bus.subscribe(before)
    bus.subscribe(broken)
    bus.subscribe(after)
    published = [bus.publish("log", n=n) for n in range(4)]
    assert before.events == published and after.events == published
    assert len(bus.errors) == 2
    assert all("broken" in e and "RuntimeError" in e for e in bus.errors)
    assert "broken on 1" in bus.errors[0] and "broken on 3" in bus.errors[1]


def test_a_subscriber_raising_under_concurrent_publishing_is_counted_once_per_delivery() -> None:
    bus = EventBus()
    seen = Events()

    def broken(event: RunEvent) -> None:
        raise ValueError("no")

    bus.subscribe(broken)
    bus.subscribe(seen)
    hammer(bus)
    assert len(seen.events) == THREADS * EACH and len(bus.errors) == THREADS * EACH


def test_unsubscribe_stops_delivery_and_is_harmless_twice() -> None:
    bus = EventBus()
    kept, dropped = Events(), Events()
    bus.subscribe(kept)
    stop = bus.subscribe(dropped)
    bus.publish("log", n=1)
    stop()
    stop()
    bus.publish("log", n=2)
    assert [e.seq for e in kept.events] == [1, 2] and [e.seq for e in dropped.events] == [1]


def test_a_subscriber_may_unsubscribe_itself_while_being_delivered_to() -> None:
    bus = EventBus()
    after = Events()
    calls: list[int] = []
    stop: list[object] = []

    def once(event: RunEvent) -> None:
        calls.append(event.seq)
        unsubscribe = stop[0]
        assert callable(unsubscribe)
        unsubscribe()

    stop.append(bus.subscribe(once))
    bus.subscribe(after)
    bus.publish("log")
    bus.publish("log")
    assert calls == [1] and [e.seq for e in after.events] == [1, 2] and bus.errors == []
