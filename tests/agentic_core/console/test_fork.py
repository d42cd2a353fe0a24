"""Resuming and forking a run from the console: a fork starts a new run from the checkpoint the slider points at
(its files up to then, its origin in run.json and the trace) and never alters the original; it flies on to the
end. Hostile: a run or checkpoint that is not there, a path for a run id, a request without the token or from
another Origin: each refused, and no folder is made."""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from starlette.testclient import TestClient

from agentic_core.console import ConsoleServer
from agentic_core.console.access import Guard
from agentic_core.console.app import build_app
from agentic_core.console.launch import Launcher
from agentic_core.console.runs import list_runs, replay
from agentic_core.contracts.errors import InputError
from agentic_core.run.fork import checkpoints, fork_run
from agentic_core.run.runner import MissionRun, RunSettings
from tests.waiting import wait_for

from ..platform.conftest import EMERGENCY, NEAR, PARAMS, of_kind, trace

TOKEN = "a-test-token-0123456789"
BASE = "http://127.0.0.1:8765"
GOOD = {"authorization": f"Bearer {TOKEN}", "origin": BASE}


@pytest.fixture(scope="module")
def flown(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """The emergency mission over the near scene, flown to its end once for the module: (runs dir, run id)."""
    runs = tmp_path_factory.mktemp("flown") / "runs"
    settings = RunSettings(mission=EMERGENCY, scene=NEAR, runs_dir=runs, params=PARAMS, camera_hz=5.0)
    result = MissionRun(settings).execute()
    return runs, result.run_id


@pytest.fixture
def runs(flown: tuple[Path, str], tmp_path: Path) -> tuple[Path, str]:
    """A copy of the flown run's folder for one test."""
    source, run_id = flown
    shutil.copytree(source / run_id, tmp_path / "runs" / run_id)
    return tmp_path / "runs", run_id


def digest(folder: Path) -> dict[str, str]:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


def middle(runs_dir: Path, run_id: str) -> Any:
    """A checkpoint mid-flight: the last of those taken at its time on the vehicle's clock (the one the slider
    picks at that time)."""
    marks = [m for m in checkpoints(runs_dir / run_id, run_id) if m.sim_t is not None and m.sim_t > 20.0]
    chosen = marks[len(marks) // 2]
    return [m for m in marks if m.sim_t == chosen.sim_t][-1]


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_a_fork_starts_from_its_checkpoint_leaves_the_original_alone_and_flies_on(runs: tuple[Path, str]) -> None:
    runs_dir, run_id = runs
    before = digest(runs_dir / run_id)
    mark = middle(runs_dir, run_id)
    new_id = fork_run(runs_dir, run_id, mark.id)
    assert digest(runs_dir / run_id) == before  # not a byte of the original changed, no file added
    fork = runs_dir / new_id
    record = json.loads((fork / "run.json").read_text())
    assert record["run_id"] == new_id and record["forked_from"]["run_id"] == run_id
    assert record["forked_from"]["checkpoint_id"] == mark.id
    copied = trace(fork)
    assert copied[-1]["event"] == "fork" and copied[-1]["forked_from"] == run_id
    assert [r["seq"] for r in copied] == list(range(1, len(copied) + 1))
    assert len(copied) < len(trace(runs_dir / run_id))
    samples = [json.loads(line) for line in (fork / "telemetry.jsonl").read_text().splitlines()]
    assert samples and max(s["time_s"] for s in samples) <= mark.sim_t + 1e-6
    with sqlite3.connect(fork / "checkpoints.db") as db:
        threads = db.execute("SELECT DISTINCT thread_id FROM agentic_checkpoints").fetchall()
        newest = db.execute("SELECT checkpoint_id FROM agentic_checkpoints ORDER BY seq DESC LIMIT 1").fetchone()
    assert threads == [(new_id,)] and newest == (mark.id,)
    result = MissionRun.resume(runs_dir, new_id).execute()  # what the console's child process does
    records = trace(result.run_dir)
    resumed = [r for r in of_kind(records, "run") if r.get("event") == "resume"]
    assert resumed and resumed[0]["sim_t"] >= mark.sim_t - 1.0  # the vehicle went on from where it was then
    assert [r["seq"] for r in records] == list(range(1, len(records) + 1))
    assert result.summary.outcome in ("completed", "degraded", "returned")
    assert digest(runs_dir / run_id) == before
    listed = {r["id"]: r for r in list_runs(runs_dir)}
    assert listed[new_id]["outcome"] == result.summary.outcome
    assert replay(runs_dir, new_id)["forked_from"]["run_id"] == run_id


@pytest.fixture
def client(runs: tuple[Path, str]) -> Iterator[tuple[TestClient, Path, str, Launcher]]:
    runs_dir, run_id = runs
    launcher = Launcher(runs_dir)
    app = build_app(runs_dir, Guard(TOKEN, loopback_only=True), None, launcher)
    try:
        yield TestClient(app, base_url=BASE), runs_dir, run_id, launcher
    finally:
        launcher.stop()


@pytest.mark.parametrize(
    "headers",
    [{}, {"origin": BASE}, {"authorization": f"Bearer {TOKEN}"},
     {"authorization": f"Bearer {TOKEN}", "origin": "http://evil.example"},
     {"authorization": f"Bearer {TOKEN}", "origin": "http://127.0.0.1:9999"}],
    ids=["bare", "no-token", "no-origin", "evil-origin", "other-port"],
)  # fmt: skip
@pytest.mark.parametrize("action", ["fork", "resume"])
def test_a_fork_or_resume_without_the_token_or_from_another_origin_is_refused(
    client: tuple[TestClient, Path, str, Launcher], headers: dict[str, str], action: str
) -> None:
    http, runs_dir, run_id, launcher = client
    before = sorted(p.name for p in runs_dir.iterdir())
    mark = middle(runs_dir, run_id)
    response = http.post(f"/api/runs/{run_id}/{action}", json={"checkpoint": mark.id}, headers=headers)
    assert response.status_code == 403, response.text
    assert sorted(p.name for p in runs_dir.iterdir()) == before and launcher.running() == []


@pytest.mark.parametrize(
    ("path", "body", "status", "says"),
    [
        ("/api/runs/no-such-run/fork", {"checkpoint": "x"}, 404, "no run"),
        ("/api/runs/no-such-run/resume", {}, 404, "no run"),
        ("/api/runs/{run}/fork", {"checkpoint": "not-a-checkpoint"}, 404, "no checkpoint"),
        ("/api/runs/{run}/fork", {}, 400, "which checkpoint"),
        ("/api/runs/{run}/fork", {"checkpoint": ["a"]}, 400, "which checkpoint"),
        ("/api/runs/{run}/explode", {}, 404, None),
        ("/api/runs/../fork", {"checkpoint": "x"}, 404, None),
        ("/api/runs/..%2F..%2Fetc/fork", {"checkpoint": "x"}, 404, None),
        ("/api/runs/%2e%2e/resume", {}, 404, None),
        ("/api/runs/.hidden/resume", {}, 404, None),
    ],
)
def test_a_fork_of_what_is_not_there_is_refused_and_makes_nothing(
    client: tuple[TestClient, Path, str, Launcher], path: str, body: dict[str, Any], status: int, says: str | None
) -> None:
    http, runs_dir, run_id, launcher = client
    before = sorted(p.name for p in runs_dir.parent.rglob("*"))
    response = http.post(path.replace("{run}", run_id), json=body, headers=GOOD)
    assert response.status_code == status, response.text
    if says:
        assert says in response.json()["error"]
    assert sorted(p.name for p in runs_dir.parent.rglob("*")) == before and launcher.running() == []


def test_fork_run_refuses_a_path_and_a_missing_run(tmp_path: Path) -> None:
    for bad in ("../x", "/etc", "a/b", ".."):
        with pytest.raises(InputError, match="not a run id"):
            fork_run(tmp_path, bad, "c1")
    with pytest.raises(InputError, match="does not exist"):
        fork_run(tmp_path, "nothing-here", "c1")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.timeout(120)
def test_resume_from_the_api_goes_on_with_the_run_in_a_child_and_a_second_is_refused(
    client: tuple[TestClient, Path, str, Launcher],
) -> None:
    http, runs_dir, run_id, launcher = client
    ended = len(trace(runs_dir / run_id))
    first = http.post(f"/api/runs/{run_id}/resume", json={}, headers=GOOD)
    assert first.status_code == 200 and first.json()["run_id"] == run_id
    again = http.post(f"/api/runs/{run_id}/resume", json={}, headers=GOOD)
    assert again.status_code == 409 and "already flying" in again.json()["error"]
    wait_for(lambda: not launcher.running(), timeout_s=90.0, what="the resumed run to end")
    more = trace(runs_dir / run_id)[ended:]
    assert [r.get("event") for r in of_kind(more, "run")] == ["resume", "end"], more


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_fork_from_here_in_the_browser_starts_a_new_run_that_flies_and_is_followed(
    browser: Any, runs: tuple[Path, str]
) -> None:
    runs_dir, run_id = runs
    before = digest(runs_dir / run_id)
    mark = middle(runs_dir, run_id)
    with ConsoleServer(runs_dir, port=0) as server:
        page = browser.new_page()
        requested: list[str] = []
        page.on("request", lambda request: requested.append(request.url))
        page.goto(server.url)
        page.wait_for_function("() => document.getElementById('status').textContent.endsWith('replay')")
        page.evaluate(
            f"() => {{ const s = document.getElementById('slider'); s.value = {mark.sim_t}; "
            "s.dispatchEvent(new Event('input')); }"
        )
        at = float(page.evaluate("() => document.getElementById('slider').value"))  # snapped to the slider's step
        picked = [m for m in checkpoints(runs_dir / run_id, run_id) if m.sim_t is not None and m.sim_t <= at + 1e-6]
        fork = page.locator("#fork-run")
        assert fork.is_visible() and f"step {picked[-1].step}" in fork.inner_text()
        fork.click()
        page.wait_for_function("() => document.getElementById('status').textContent.includes('fork of')")
        new_id = page.evaluate("() => window.consoleState.runId")
        assert new_id != run_id and page.locator("#runs").input_value() == new_id
        page.wait_for_function(  # the child flies it to its end; the page follows its files
            "() => document.getElementById('status').textContent.endsWith('replay')", timeout=180_000
        )
        assert page.evaluate("() => window.consoleState.events.some(e => e.kind === 'run' && e.event === 'resume')")
        page.close()
    own = f"http://127.0.0.1:{server.port}/"
    assert requested and all(url.startswith(own) for url in requested)
    assert digest(runs_dir / run_id) == before
    assert [r.get("event") for r in of_kind(trace(runs_dir / new_id), "run")][-3:] == ["fork", "resume", "end"]


@pytest.mark.timeout(120)
def test_replay_draws_the_world_model_of_the_time_on_the_slider(browser: Any, runs: tuple[Path, str]) -> None:
    runs_dir, run_id = runs
    changes = [json.loads(line) for line in (runs_dir / run_id / "world_map.jsonl").read_text().splitlines()]
    decisions = (runs_dir / run_id / "world_models.jsonl").read_text().splitlines()
    assert len(changes) > 3 * len(decisions)  # not only the worlds of decisions: every change the map shows
    worlds = replay(runs_dir, run_id)["worlds"]
    assert [w["t"] for w in worlds] == sorted(w["t"] for w in worlds)
    seen = [w for w in changes if w["objects"]]
    first, last = seen[0], seen[-1]
    with ConsoleServer(runs_dir, port=0) as server:
        page = browser.new_page()
        page.goto(server.url)
        page.wait_for_function("() => document.getElementById('status').textContent.endsWith('replay')")
        for target in (first, last):
            page.evaluate(
                f"() => {{ const s = document.getElementById('slider'); s.value = {target['t'] + 0.05}; "
                "s.dispatchEvent(new Event('input')); }"
            )
            shown = page.evaluate("() => window.consoleState.shownWorld")
            expected = max((w for w in worlds if w["t"] <= float(page.locator("#slider").input_value()) + 0.01),
                           key=lambda w: w["t"])  # fmt: skip
            assert shown["t"] == expected["t"] and shown["objects"] == expected["objects"]
            drawn = page.evaluate("() => document.querySelectorAll('.leaflet-overlay-pane path').length")
            assert drawn >= 2 * len(shown["objects"])  # an ellipse and a dot for each object, beside the map's own
        page.close()
