"""Who may use the console: a console beyond this machine without a token is refused at start, from either
command; every change needs the token in its header and the console's own Origin, and a refused one changes
nothing."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
from pathlib import Path
from typing import Any

import httpx
import pytest
from starlette.testclient import TestClient

from agentic_core.agent.control import ControlPort
from agentic_core.console.access import TOKEN_ENV, Guard, check_bind
from agentic_core.console.app import Live, build_app
from agentic_core.console.cli import main as console_main
from agentic_core.console.feed import LiveFeed
from agentic_core.contracts.errors import InputError
from agentic_core.run.cli import main as run_main

TOKEN = "a-test-token-0123456789"
BASE = "http://127.0.0.1:8765"
REPO = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("host", ["0.0.0.0", "192.168.1.20", "::", "console.example.org"])
def test_binding_beyond_this_machine_without_a_token_is_a_clear_error(host: str) -> None:
    with pytest.raises(InputError, match=rf"binding {host} .*needs a token"):
        check_bind(host, None)
    check_bind(host, TOKEN)  # with one it may


@pytest.mark.parametrize("host", ["127.0.0.1", "127.0.0.2", "::1", "localhost"])
def test_loopback_needs_no_token_given_but_a_short_one_is_refused(host: str) -> None:
    check_bind(host, None)
    with pytest.raises(InputError, match="too short"):
        check_bind(host, "abc")


def test_the_console_command_refuses_0_0_0_0_without_a_token(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    monkeypatch.delenv(TOKEN_ENV, raising=False)
    code = console_main(["--host", "0.0.0.0", "--port", "0", "--runs-dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and "0.0.0.0" in err and "needs a token" in err and "Traceback" not in err


def test_run_console_refuses_0_0_0_0_without_a_token_before_anything_flies(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    monkeypatch.delenv(TOKEN_ENV, raising=False)
    runs = tmp_path / "runs"
    code = run_main([str(REPO / "missions" / "hajj_emergency.yaml"), "--console", "--console-host", "0.0.0.0",
                     "--runs-dir", str(runs), "--quiet"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and "needs a token" in err and "Traceback" not in err
    assert not runs.exists()  # no run folder: nothing was built, nothing flew


class Recorder:
    """A live run's control port, for the app alone: a real one, with every command it passes on recorded."""

    def __init__(self) -> None:
        self.commands: list[tuple[str, dict[str, Any]]] = []
        self.port = ControlPort(on_command=lambda name, detail: self.commands.append((name, detail)))


@pytest.fixture
def steered(tmp_path: Path) -> tuple[TestClient, Recorder]:
    recorder = Recorder()
    app = build_app(tmp_path, Guard(TOKEN, loopback_only=True), Live(LiveFeed(), recorder.port))
    return TestClient(app, base_url=BASE), recorder


GOOD = {"authorization": f"Bearer {TOKEN}", "origin": BASE}


@pytest.mark.parametrize(
    "headers",
    [
        {},  # nothing
        {"origin": BASE},  # the right Origin, no token
        {"authorization": "Bearer wrong-token-0123456789", "origin": BASE},
        {"authorization": f"Bearer {TOKEN}"},  # no Origin
        {"authorization": f"Bearer {TOKEN}", "origin": "http://evil.example"},
        {"authorization": f"Bearer {TOKEN}", "origin": "http://127.0.0.1:9999"},  # another local port
        {"authorization": f"Bearer {TOKEN}", "origin": "null"},
        {"authorization": f"Basic {TOKEN}", "origin": BASE},
    ],
    ids=["bare", "no-token", "wrong-token", "no-origin", "evil-origin", "other-port", "null-origin", "basic"],
)
@pytest.mark.parametrize("path", ["/api/control/abort", "/api/control/pause", "/api/questions/q1"])
def test_a_change_without_the_token_or_from_another_origin_is_refused_and_changes_nothing(
    steered: tuple[TestClient, Recorder], headers: dict[str, str], path: str
) -> None:
    client, recorder = steered
    body = {"approve": True} if "questions" in path else {}
    response = client.post(path, json=body, headers=headers)
    assert response.status_code == 403, response.text
    assert recorder.commands == []
    assert recorder.port.stop_requested() is None and not recorder.port.paused


def test_the_token_in_the_url_does_not_authorise_a_change(steered: tuple[TestClient, Recorder]) -> None:
    client, recorder = steered
    response = client.post(f"/api/control/abort?token={TOKEN}", json={}, headers={"origin": BASE})
    assert response.status_code == 403 and recorder.commands == []


def test_a_rebound_host_name_is_refused_even_with_its_own_origin(tmp_path: Path) -> None:
    recorder = Recorder()
    app = build_app(tmp_path, Guard(TOKEN, loopback_only=True), Live(LiveFeed(), recorder.port))
    client = TestClient(app, base_url="http://attacker.example:8765")
    response = client.post("/api/control/land", headers={"authorization": f"Bearer {TOKEN}",
                                                         "origin": "http://attacker.example:8765"})  # fmt: skip
    assert response.status_code == 403 and "not this machine" in response.json()["error"]
    assert recorder.commands == []


@pytest.mark.parametrize("command", ["pause", "resume", "hold", "rtl", "land", "abort"])
def test_each_command_goes_through_the_control_port_named_console(
    steered: tuple[TestClient, Recorder], command: str
) -> None:
    client, recorder = steered
    response = client.post(f"/api/control/{command}", json={"reason": "smoke"}, headers=GOOD)
    assert response.status_code == 200, response.text
    assert [(name, detail["by"]) for name, detail in recorder.commands] == [(command, "console")]
    if command in ("hold", "rtl", "land", "abort"):
        assert recorder.port.stop_requested() == command and recorder.port.stopped_by == "console"


@pytest.mark.parametrize(
    ("path", "body", "status"),
    [
        ("/api/control/takeoff", {}, 404),
        ("/api/control/__init__", {}, 404),
        ("/api/questions/q9", {"approve": True}, 404),
        ("/api/questions/q1", {"approve": "yes"}, 400),
        ("/api/questions/q1", [1, 2], 400),
    ],
)
def test_a_bad_change_is_a_clear_error_that_changes_nothing(
    steered: tuple[TestClient, Recorder], path: str, body: Any, status: int
) -> None:
    client, recorder = steered
    response = client.post(path, json=body, headers=GOOD)
    assert response.status_code == status and response.json()["error"]
    assert recorder.commands == []


def test_a_body_that_is_not_json_is_refused(steered: tuple[TestClient, Recorder]) -> None:
    client, recorder = steered
    response = client.post("/api/control/pause", content=b"\xff{not json", headers=GOOD)
    assert response.status_code == 400 and recorder.commands == []


def test_reads_need_the_token_and_the_page_forbids_other_origins(steered: tuple[TestClient, Recorder]) -> None:
    client, _ = steered
    assert client.get("/api/runs").status_code == 403
    assert client.get("/api/runs", params={"token": "wrong-token-0123456789"}).status_code == 403
    assert client.get("/api/runs", headers={"authorization": f"Bearer {TOKEN}"}).json()["live"] is True
    page = client.get("/")
    assert page.status_code == 200 and TOKEN not in page.text  # the token never sits in the page
    assert "default-src 'self'" in page.headers["content-security-policy"]
    assert "connect-src 'self'" in page.headers["content-security-policy"]


@pytest.mark.parametrize("run_id", ["..", "../etc", "%2e%2e", ".hidden", "a/b", "x" * 300])
def test_a_run_id_that_is_not_one_is_not_found(steered: tuple[TestClient, Recorder], run_id: str) -> None:
    client, _ = steered
    response = client.get(f"/api/runs/{run_id}", headers={"authorization": f"Bearer {TOKEN}"})
    assert response.status_code == 404


def test_a_port_in_use_is_a_clear_error(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code = console_main(["--port", str(port), "--runs-dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and f"cannot listen on 127.0.0.1:{port}" in err and "Traceback" not in err


def test_run_console_without_the_extra_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    monkeypatch.setitem(sys.modules, "sse_starlette", None)  # as if the extra were not installed
    runs = tmp_path / "runs"
    code = run_main([str(REPO / "missions" / "hajj_emergency.yaml"), "--console", "--runs-dir", str(runs), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and "pip install 'agentic-uavs[console]'" in err and "Traceback" not in err
    assert not runs.exists()


@pytest.mark.timeout(60)
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_the_console_command_serves_until_a_signal_and_then_exits_0(tmp_path: Path, sig: signal.Signals) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    env.pop(TOKEN_ENV, None)
    with subprocess.Popen(
        [sys.executable, "-m", "agentic_core", "console", "--port", "0", "--runs-dir", str(tmp_path)],
        cwd=REPO, env=env, stderr=subprocess.PIPE, text=True,
    ) as process:  # fmt: skip
        try:
            assert process.stderr is not None
            line = process.stderr.readline()
            url = line.split()[1]
            token = url.split("#token=")[1]
            listed = httpx.get(url.split("/#")[0] + "/api/runs", headers={"authorization": f"Bearer {token}"})
            assert listed.json() == {"runs": [], "live": False}
            process.send_signal(sig)
            assert process.wait(timeout=30) == 0
            assert "Traceback" not in process.stderr.read()
        finally:
            if process.poll() is None:
                process.kill()
