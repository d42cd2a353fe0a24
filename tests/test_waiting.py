"""The test suite's wait helper: it returns as soon as the condition holds, and fails clearly when it never does."""

import asyncio
import threading
import time

import pytest

from tests.waiting import wait_for, wait_for_async


def test_returns_the_truthy_value_once_another_thread_makes_it_true() -> None:
    box: list[str] = []
    threading.Timer(0.05, box.append, args=("ready",)).start()
    assert wait_for(lambda: box, 10, what="the box") == ["ready"]


def test_times_out_with_a_message_naming_what_it_waited_for() -> None:
    started = time.monotonic()
    with pytest.raises(AssertionError, match=r"timed out after 0\.05 s waiting for the moon to rise"):
        wait_for(lambda: False, 0.05, what="the moon to rise")
    assert time.monotonic() - started >= 0.05


def test_asks_once_more_at_the_deadline() -> None:
    calls: list[int] = []

    def second_time_lucky() -> bool:
        calls.append(1)
        return len(calls) >= 2

    assert wait_for(second_time_lucky, 0.0, interval_s=10) is True  # never sleeps the 10 s


def test_the_async_form_lets_the_loop_run() -> None:
    async def main() -> list[str]:
        box: list[str] = []
        asyncio.get_running_loop().call_later(0.02, box.append, "done")
        return await wait_for_async(lambda: box, 10, what="the callback")

    assert asyncio.run(main()) == ["done"]
    with pytest.raises(AssertionError, match="waiting for nothing"):
        asyncio.run(wait_for_async(lambda: 0, 0.02, what="nothing"))
