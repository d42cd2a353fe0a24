"""A swarm run's UAVs share one terminal for their questions: one reader of the input, one question on the screen at
a time, each naming its UAV, so an answer is the answer to the question it was typed under — even when two UAVs ask
at once (each UAV's run reading the terminal itself had two readers race for every line)."""

from __future__ import annotations

import io
import os
import threading

import pytest

from agentic_core.agent.control import OperatorAnswer
from agentic_core.run.swarm_operator import SharedTerminal
from tests.waiting import wait_for

pytestmark = pytest.mark.timeout(60)


def test_two_uavs_asking_at_once_take_turns_and_each_gets_its_own_answer() -> None:
    read_fd, write_fd = os.pipe()
    with os.fdopen(read_fd, "r") as answers, os.fdopen(write_fd, "w") as keyboard:
        screen = io.StringIO()
        terminal = SharedTerminal(answers, screen, timeout_s=30.0)
        got: dict[str, OperatorAnswer] = {}
        askers = [
            threading.Thread(target=lambda u=uav: got.update({u: terminal.for_uav(u)({"step": "land_near"})}))
            for uav in ("uav-1", "uav-2")
        ]
        for asker in askers:
            asker.start()
        wait_for(lambda: ">>> operator:" in screen.getvalue(), timeout_s=10.0, what="the first question")
        first = "uav-1" if "uav-1: approve land_near?" in screen.getvalue() else "uav-2"
        second = "uav-2" if first == "uav-1" else "uav-1"
        assert screen.getvalue().count(">>> operator:") == 1 and not got  # the second waits its turn, unasked
        keyboard.write("y\n")
        keyboard.flush()
        wait_for(lambda: screen.getvalue().count(">>> operator:") == 2, timeout_s=10.0, what="the second question")
        assert set(got) == {first} and got[first].approved  # the first answer went to the first question
        assert f"{second}: approve land_near?" in screen.getvalue().split(">>> operator:")[2]
        keyboard.write("no\n")
        keyboard.flush()
        for asker in askers:
            asker.join(timeout=10.0)
    assert not got[second].approved and got[second].said == "no"


def test_a_question_unanswered_declines_and_the_next_uav_is_asked() -> None:
    terminal = SharedTerminal(io.StringIO(""), io.StringIO(), timeout_s=0.2)  # input ended: nobody will answer
    first = terminal.for_uav("uav-1")({"step": "land_near"})
    second = terminal.for_uav("uav-2")({"step": "land_near"})
    assert not first.approved and not second.approved and "input ended" in second.why
