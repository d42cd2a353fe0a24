"""The live feed: a page that opens late catches up from one snapshot taken with its subscription (nothing lost
between), telemetry goes out at most at its rate, a page that stops reading is dropped rather than slowing the run,
and an answered question leaves every page."""

from __future__ import annotations

import asyncio
import json
import threading
from pathlib import Path
from typing import Any

import pytest
from starlette.testclient import TestClient

from agentic_core.agent.control import ControlPort
from agentic_core.console.access import Guard
from agentic_core.console.app import Live, build_app
from agentic_core.console.feed import QUEUE_LIMIT, LiveFeed
from tests.waiting import wait_for

TOKEN = "a-test-token-0123456789"
BASE = "http://127.0.0.1:8765"


def sample(t: float) -> dict[str, Any]:
    return {"time_s": t, "lat_deg": 21.4, "lon_deg": 39.9, "alt_m": 10.0}


def drain(queue: asyncio.Queue[str | None]) -> list[dict[str, Any]]:
    out = []
    while not queue.empty():
        text = queue.get_nowait()
        out.append(json.loads(text) if text is not None else {"type": None})
    return out


def test_telemetry_goes_out_at_most_at_its_rate_and_the_trail_by_the_vehicle_clock() -> None:
    now = [0.0]
    feed = LiveFeed(telemetry_hz=10.0, clock=lambda: now[0])
    loop = asyncio.new_event_loop()
    try:
        page, first = feed.connect(loop)
        assert json.loads(first)["type"] == "snapshot"
        for i in range(100):  # 100 samples, 0.01 s of wall time and 0.05 s of the vehicle's clock apart
            now[0] = i * 0.01
            feed.telemetry(sample(i * 0.05))
        loop.run_until_complete(asyncio.sleep(0))
        sent = [m for m in drain(page.queue) if m["type"] == "telemetry"]
    finally:
        loop.close()
    assert len(sent) == 10  # one second of wall time at 10 Hz
    assert len(feed.snapshot()["trail"]) == 10  # 5 s of the vehicle's clock, a point every 0.5 s
    assert feed.snapshot()["telemetry"]["time_s"] == 99 * 0.05  # the latest is always kept


def test_a_page_that_stops_reading_is_dropped_and_the_run_goes_on() -> None:
    feed = LiveFeed()
    loop = asyncio.new_event_loop()
    try:
        page, _ = feed.connect(loop)
        for seq in range(QUEUE_LIMIT + 50):
            feed.event({"kind": "log", "seq": seq})
            if seq % 100 == 0:
                loop.run_until_complete(asyncio.sleep(0))  # deliver what was handed over so far
        loop.run_until_complete(asyncio.sleep(0))
        assert page.dropped and feed.pages == 0
        assert drain(page.queue)[-1] == {"type": None}  # its stream is told to end
    finally:
        loop.close()


def test_an_answered_question_leaves_the_snapshot_and_a_timed_out_one_too() -> None:
    feed = LiveFeed()
    feed.question("q1", {"step": "land_near"})
    assert [q["id"] for q in feed.snapshot()["questions"]] == ["q1"]
    feed.event({"kind": "control", "command": "approve", "question": "q1", "by": "console"})
    assert feed.snapshot()["questions"] == []
    feed.question("q2", {"step": "release_kit"})
    feed.event({"kind": "approval", "answer": False, "via": "operator"})  # no answer in time: declined
    assert feed.snapshot()["questions"] == []


class Asked:
    """A console over a control port whose run waits on one question (``land_near``), asked from its own thread."""

    def __init__(self, tmp_path: Path, timeout_s: float = 30.0, request: dict[str, Any] | None = None) -> None:
        self.commands: list[tuple[str, dict[str, Any]]] = []
        self.port = ControlPort(on_command=lambda name, detail: self.commands.append((name, detail)))
        feed = LiveFeed()
        self.port.on_question(lambda q: feed.question(q.id, q.request))
        self.client = TestClient(build_app(tmp_path, Guard(TOKEN), Live(feed, self.port)), base_url=BASE)
        self.answers: list[Any] = []
        request = request or {"step": "land_near"}
        ask = lambda: self.answers.append(self.port.ask(request, timeout_s=timeout_s))  # noqa: E731
        self.asking = threading.Thread(target=ask)
        self.asking.start()
        (self.question,) = wait_for(lambda: feed.snapshot()["questions"], timeout_s=10.0, what="the question")

    def post(self, body: dict[str, Any]) -> Any:
        headers = {"authorization": f"Bearer {TOKEN}", "origin": BASE}
        return self.client.post(f"/api/questions/{self.question['id']}", json=body, headers=headers)

    def answer(self) -> Any:
        self.asking.join(timeout=10.0)
        return self.answers[0]


def test_a_page_answers_a_waiting_question_and_the_run_hears_it(tmp_path: Path) -> None:
    asked = Asked(tmp_path)
    assert asked.post({"approve": False, "reason": "crowd"}).status_code == 200
    answer = asked.answer()
    assert answer.approved is False and answer.said == "crowd"
    assert asked.commands == [("decline", {"by": "console", "question": "q1", "step": "land_near", "reason": "crowd"})]
    assert asked.post({"approve": True}).status_code == 404  # answered once: a second click changes nothing


@pytest.mark.parametrize(
    ("body", "status"),
    [
        ({"approve": True, "args": {"offset_m": 8}}, 200),
        ({"approve": False, "args": {"offset_m": 8}}, 400),  # edits come with an approval only
        ({"approve": True, "args": [["offset_m", 8]]}, 400),  # not an object
        ({"approve": True, "args": {}}, 400),  # nothing edited is not an edit
        ({"approve": True, "args": {f"a{k}": k for k in range(21)}}, 400),  # more than a step has
    ],
    ids=["edit", "with-a-decline", "not-an-object", "empty", "too-many"],
)
def test_an_approval_may_carry_edited_arguments_and_nothing_else_does(
    tmp_path: Path, body: dict[str, Any], status: int
) -> None:
    asked = Asked(tmp_path, timeout_s=5.0)
    assert asked.post(body).status_code == status
    if status != 200:
        asked.port.decline(asked.question["id"], by="test")  # a refused request answered nothing: it still waits
    answer = asked.answer()
    assert answer.approved is (status == 200)
    assert answer.args == (body["args"] if status == 200 else None)


def test_an_edit_of_an_argument_the_step_has_not_is_refused_and_the_question_still_waits(tmp_path: Path) -> None:
    asked = Asked(tmp_path, timeout_s=5.0, request={"step": "land_near", "args": {"target_id": "P-1", "offset_m": 5}})
    refused = asked.post({"approve": True, "args": {"offset_m": 8, "lat": 0.0}})
    assert refused.status_code == 400 and "lat: not an argument of this step (offset_m, target_id)" in refused.text
    assert asked.commands == [] and asked.post({"approve": True, "args": {"offset_m": 8}}).status_code == 200
    assert asked.answer().args == {"offset_m": 8}
