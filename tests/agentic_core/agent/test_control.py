"""ControlPort: commands from other threads, the first stop command standing, answers by id and oldest first,
questions that time out or are released by a stop, an operator that breaks, and ``on_command`` told of all."""

from __future__ import annotations

import threading
import time
from typing import Any

import pytest

from agentic_core.agent import ControlPort, OperatorAnswer

from .fakes import wait_for

pytestmark = pytest.mark.timeout(60)


class Commands:
    """An ``on_command`` that records every command, thread-safe."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.seen: list[tuple[str, dict[str, Any]]] = []

    def __call__(self, name: str, detail: dict[str, Any]) -> None:
        with self._lock:
            self.seen.append((name, detail))

    def names(self) -> list[str]:
        with self._lock:
            return [name for name, _ in self.seen]


def in_thread(work: Any) -> threading.Thread:
    thread = threading.Thread(target=work, daemon=True)
    thread.start()
    return thread


def asked(port: ControlPort, request: dict[str, Any], timeout_s: float) -> tuple[threading.Thread, list[Any]]:
    """``port.ask`` on a thread of its own; its answer lands in the returned list."""
    box: list[Any] = []
    return in_thread(lambda: box.append(port.ask(request, timeout_s))), box


def test_pause_from_another_thread_holds_the_waiter_until_resume() -> None:
    port = ControlPort()
    port.pause(by="console")
    released = threading.Event()

    def wait() -> None:
        port.wait_while_paused(poll_s=5.0)
        released.set()

    waiter = in_thread(wait)
    assert not released.wait(0.2)  # held: nothing releases it but a resume (or a stop)
    in_thread(lambda: port.resume(by="console")).join(5)
    assert released.wait(5) and not port.paused
    waiter.join(5)


@pytest.mark.parametrize("stop", ["abort", "rtl", "land"])
def test_a_stop_command_releases_a_paused_waiter(stop: str) -> None:
    port = ControlPort()
    port.pause()
    waiter = in_thread(lambda: port.wait_while_paused(poll_s=5.0))
    in_thread(lambda: getattr(port, stop)())
    waiter.join(5)
    assert not waiter.is_alive() and port.stop_requested() == stop and port.paused  # stopped, still marked paused


def test_the_first_stop_command_stands_among_racing_threads() -> None:
    port = ControlPort()
    port.abort("first, on purpose")
    barrier = threading.Barrier(6, timeout=5)

    def race(command: str) -> None:
        barrier.wait()
        if command == "abort":
            port.abort("later")
        else:
            getattr(port, command)()

    workers = [in_thread(lambda c=c: race(c)) for c in ["abort", "rtl", "land"] * 2]
    for worker in workers:
        worker.join(5)
    assert port.stop_requested() == "abort" and port.stop_reason == "first, on purpose"


def test_with_racing_stop_commands_exactly_one_wins_and_never_changes() -> None:
    port = ControlPort()
    barrier = threading.Barrier(3, timeout=5)
    seen: list[str | None] = []

    def race(command: str) -> None:
        barrier.wait()
        getattr(port, command)()
        seen.append(port.stop_requested())

    workers = [in_thread(lambda c=c: race(c)) for c in ("abort", "rtl", "land")]
    for worker in workers:
        worker.join(5)
    winner = port.stop_requested()
    assert winner in ("abort", "rtl", "land") and seen == [winner] * 3


def test_approve_and_decline_by_id_and_oldest_first() -> None:
    port = ControlPort()
    threads = [asked(port, {"step": f"s{n}"}, 30) for n in range(3)]
    wait_for(lambda: len(port.pending()) == 3, what="three questions pending")
    first, second, third = (q.id for q in port.pending())
    assert [q.request["step"] for q in port.pending()] == ["s0", "s1", "s2"]  # oldest first
    assert port.decline(third, "not that one")
    assert port.approve()  # the oldest: s0
    assert [q.id for q in port.pending()] == [second]
    assert port.approve(second, "ok")
    for thread, _ in threads:
        thread.join(5)
    answers = [box[0] for _, box in threads]
    assert [a.approved for a in answers] == [True, True, False]
    assert answers[2].said == "not that one" and answers[1].said == "ok" and answers[0].why == "approved by operator"
    assert first not in {q.id for q in port.pending()}


def test_answering_when_nothing_is_pending_or_an_unknown_id_returns_false() -> None:
    commands = Commands()
    port = ControlPort(on_command=commands)
    assert port.approve() is False and port.decline() is False
    thread, box = asked(port, {"step": "s"}, 30)
    wait_for(lambda: len(port.pending()) == 1, what="the question")
    assert port.approve("q999") is False and port.decline("nope") is False
    question = port.pending()[0].id
    assert port.approve(question)
    thread.join(5)
    assert port.approve(question) is False and port.decline(question) is False  # answered already
    assert box[0].approved and commands.names() == ["approve"]


def test_ask_times_out_to_a_decline() -> None:
    port = ControlPort()
    started = time.monotonic()
    answer = port.ask({"step": "land"}, timeout_s=0.2)
    assert not answer.approved and "no answer in 0.2 s" in answer.why
    assert 0.15 <= time.monotonic() - started < 5 and port.pending() == []


@pytest.mark.parametrize("stop", ["abort", "rtl", "land"])
def test_ask_is_released_by_a_stop_command_with_a_decline(stop: str) -> None:
    port = ControlPort()
    thread, box = asked(port, {"step": "land"}, 60)
    wait_for(lambda: len(port.pending()) == 1, what="the question")
    getattr(port, stop)()
    thread.join(5)
    assert not thread.is_alive() and not box[0].approved and f"stopped ({stop})" in box[0].why


def test_ask_after_a_stop_declines_at_once() -> None:
    port = ControlPort()
    port.land()
    started = time.monotonic()
    assert not port.ask({"step": "s"}, timeout_s=30).approved and time.monotonic() - started < 5


def test_answer_with_an_operator_that_raises_declines() -> None:
    port = ControlPort()

    def broken(request: dict[str, Any]) -> OperatorAnswer:
        raise KeyError(request["nothing"])

    port.answer_with(broken)
    answer = port.ask({"step": "drop"}, timeout_s=10)
    assert not answer.approved and "the operator failed (KeyError)" in answer.why


def test_answer_with_an_operator_answers_on_a_thread_of_its_own() -> None:
    port = ControlPort()
    asking = threading.get_ident()
    threads: list[int] = []

    def operator(request: dict[str, Any]) -> OperatorAnswer:
        threads.append(threading.get_ident())
        return OperatorAnswer(request["step"] == "good", "said so", "by the script")

    port.answer_with(operator)
    assert port.ask({"step": "good"}, 10).approved and not port.ask({"step": "bad"}, 10).approved
    assert len(threads) == 2 and asking not in threads


def test_every_command_reaches_on_command_with_who_gave_it() -> None:
    commands = Commands()
    port = ControlPort(on_command=commands)
    thread, _ = asked(port, {"step": "drop"}, 30)
    wait_for(lambda: len(port.pending()) == 1, what="the question")
    question = port.pending()[0].id
    port.decline(question, "too close", by="console")
    thread.join(5)
    for command in ("pause", "resume"):
        in_thread(lambda c=command: getattr(port, c)(by="console")).join(5)
    port.rtl(by="tester")
    port.abort("late", by="tester")  # does not stand, but is still told
    port.land()
    assert commands.names() == ["decline", "pause", "resume", "rtl", "abort", "land"]
    detail = dict(commands.seen)
    assert detail["decline"] == {"by": "console", "question": question, "step": "drop", "reason": "too close"}
    assert detail["rtl"] == {"by": "tester"} and detail["abort"] == {"by": "tester", "reason": "late"}
    assert detail["land"] == {"by": "operator"} and port.stop_requested() == "rtl"
