"""A change's body is bounded: JSON nested past the shared limit is a 400 saying so (never a RecursionError and a
500), and a body over 64 KiB is a 413, refused on its Content-Length before it is read and cut off at the limit
when it streams, so no body costs the live run more memory than the limit."""

from __future__ import annotations

import asyncio
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from starlette.testclient import TestClient

from agentic_core.console import ConsoleServer
from agentic_core.console.access import Guard
from agentic_core.console.app import Live, build_app
from agentic_core.console.bodies import MAX_BODY_BYTES
from agentic_core.console.feed import LiveFeed

from .test_access import BASE, GOOD, TOKEN, Recorder

CHANGES = ["/api/control/pause", "/api/questions/q1", "/api/runs/some-run/resume", "/api/runs/some-run/fork"]


@pytest.fixture
def steered(tmp_path: Path) -> tuple[TestClient, Recorder]:
    recorder = Recorder()
    app = build_app(tmp_path, Guard(TOKEN, loopback_only=True), Live(LiveFeed(), recorder.port))
    return TestClient(app, base_url=BASE), recorder


@pytest.mark.parametrize("path", CHANGES)
@pytest.mark.parametrize("depth", [101, 5_000, 30_000])
def test_json_nested_too_deep_is_a_400_that_says_so(
    steered: tuple[TestClient, Recorder], path: str, depth: int
) -> None:
    client, recorder = steered
    body = b"[" * depth + b"]" * depth  # within the size limit: the depth alone is refused
    assert len(body) <= MAX_BODY_BYTES
    response = client.post(path, content=body, headers=GOOD)
    assert response.status_code == 400
    assert "nested more than 100 levels" in response.json()["error"]
    assert recorder.commands == []


def test_json_just_within_the_depth_limit_is_judged_on_its_content(steered: tuple[TestClient, Recorder]) -> None:
    client, recorder = steered
    inner: Any = "x"
    for _ in range(99):
        inner = [inner]
    response = client.post("/api/control/pause", json={"reason": inner}, headers=GOOD)  # 100 levels with the object
    assert response.status_code == 200 and [name for name, _ in recorder.commands] == ["pause"]


@pytest.mark.parametrize("path", CHANGES)
def test_a_body_over_the_limit_is_a_413_and_changes_nothing(steered: tuple[TestClient, Recorder], path: str) -> None:
    client, recorder = steered
    body = b'{"reason": "' + b"x" * MAX_BODY_BYTES + b'"}'
    response = client.post(path, content=body, headers=GOOD)
    assert response.status_code == 413 and "larger than" in response.json()["error"]
    assert recorder.commands == []


def test_a_body_at_the_limit_is_taken(steered: tuple[TestClient, Recorder]) -> None:
    client, recorder = steered
    head, tail = b'{"reason": "', b'"}'
    body = head + b"x" * (MAX_BODY_BYTES - len(head) - len(tail)) + tail
    assert len(body) == MAX_BODY_BYTES
    assert client.post("/api/control/pause", content=body, headers=GOOD).status_code == 200
    assert [name for name, _ in recorder.commands] == ["pause"]


def test_the_reported_deep_body_is_refused_not_a_500(steered: tuple[TestClient, Recorder]) -> None:
    client, recorder = steered
    depth = 100_000  # the tester's body: 100,000 "[" (and as many "]"), 200 KB
    response = client.post("/api/control/pause", content=b"[" * depth + b"]" * depth, headers=GOOD)
    assert response.status_code in (400, 413) and response.json()["error"]
    assert recorder.commands == []


class Drip:
    """An ASGI ``receive`` that hands out ``chunk``-sized pieces of an endless body, counting what it handed out."""

    def __init__(self, chunk: int) -> None:
        self.chunk = chunk
        self.given = 0

    async def __call__(self) -> dict[str, Any]:
        self.given += self.chunk
        return {"type": "http.request", "body": b" " * self.chunk, "more_body": True}


def asgi_post(app: Any, path: str, receive: Drip, headers: dict[str, str]) -> int:
    """Call ``app`` with one POST to ``path`` whose body comes from ``receive``; the status it answers."""
    sent: list[dict[str, Any]] = []
    scope = {
        "type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": "POST", "scheme": "http",
        "path": path, "raw_path": path.encode(), "query_string": b"", "root_path": "",
        "headers": [(k.lower().encode(), v.encode()) for k, v in {"host": "127.0.0.1:8765", **headers}.items()],
        "client": ("127.0.0.1", 50000), "server": ("127.0.0.1", 8765),
    }  # fmt: skip

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    asyncio.run(asyncio.wait_for(app(scope, receive, send), timeout=30))
    return int(next(m for m in sent if m["type"] == "http.response.start")["status"])


@pytest.fixture
def app(tmp_path: Path) -> Any:
    return build_app(tmp_path, Guard(TOKEN, loopback_only=True), Live(LiveFeed(), Recorder().port))


def test_an_endless_streamed_body_is_read_no_further_than_the_limit(app: Any) -> None:
    drip = Drip(chunk=4096)
    status = asgi_post(app, "/api/control/pause", drip, GOOD)  # no Content-Length: chunked, and endless
    assert status == 413
    assert drip.given <= MAX_BODY_BYTES + drip.chunk


def test_a_content_length_over_the_limit_is_refused_before_a_byte_is_read(app: Any) -> None:
    drip = Drip(chunk=4096)
    status = asgi_post(app, "/api/control/pause", drip, {**GOOD, "content-length": str(400 * 2**20)})
    assert status == 413 and drip.given == 0


def test_a_content_length_that_understates_the_body_does_not_lift_the_cap(app: Any) -> None:
    drip = Drip(chunk=4096)
    status = asgi_post(app, "/api/control/pause", drip, {**GOOD, "content-length": "10"})
    assert status == 413
    assert drip.given <= MAX_BODY_BYTES + drip.chunk


@pytest.mark.parametrize("length", ["-1", "ten", "1e9", " "])
def test_a_content_length_that_is_not_a_length_is_a_400(app: Any, length: str) -> None:
    drip = Drip(chunk=16)
    status = asgi_post(app, "/api/control/pause", drip, {**GOOD, "content-length": length})
    assert status == 400 and drip.given == 0


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[ConsoleServer, Recorder]]:
    recorder = Recorder()
    server = ConsoleServer(tmp_path, port=0, token=TOKEN, live=Live(LiveFeed(), recorder.port)).start()
    try:
        yield server, recorder
    finally:
        server.stop()


def test_over_http_a_large_streamed_body_is_a_413_and_the_console_serves_on(
    served: tuple[ConsoleServer, Recorder],
) -> None:
    server, recorder = served
    base = f"http://127.0.0.1:{server.port}"
    headers = {"authorization": f"Bearer {TOKEN}", "origin": base}

    def chunks() -> Iterator[bytes]:
        for _ in range(128):  # 8 MB, streamed without a Content-Length
            yield b"[" * 2**16

    with httpx.Client(timeout=30) as client:
        big = client.post(f"{base}/api/control/pause", content=chunks(), headers=headers)
        assert big.status_code == 413 and "larger than" in big.json()["error"]
        deep = client.post(f"{base}/api/control/pause", content=b"[" * 5000 + b"]" * 5000, headers=headers)
        assert deep.status_code == 400 and "nested" in deep.json()["error"]
        fine = client.post(f"{base}/api/control/pause", json={}, headers=headers)
        assert fine.status_code == 200
    assert [name for name, _ in recorder.commands] == ["pause"]
