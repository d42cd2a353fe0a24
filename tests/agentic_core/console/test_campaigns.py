"""Campaign progress in the console: a campaign rewrites its ``progress.json`` as it goes (counts done, failed
and in all, rates per system, time left) and says when it ended; the console lists the campaigns under its
directory from those files alone, says which seem stalled, shows a broken file as an error and not a crash,
and the page follows a campaign's progress as it changes."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from agentic_core.console import ConsoleServer
from agentic_core.console.campaigns import list_campaigns
from agentic_core.contracts.campaign_progress import PROGRESS_FILE, STALLED_S, CampaignProgress, SystemProgress
from evaluation.campaign import CampaignPlan, EpisodeSettings, parse_systems, run_campaign
from evaluation.campaign.progress import Progress
from flight.sim.scene_gen import generate_scene

FRAMES = 20


def progress_file(folder: Path, **fields: Any) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    now = time.time()
    data = {"campaign": folder.name, "total": 8, "done": 2, "started_at": now - 10, "updated_at": now, **fields}
    path = folder / PROGRESS_FILE
    path.write_text(CampaignProgress.model_validate(data).model_dump_json(), encoding="utf-8")
    return path


def test_progress_counts_each_system_and_its_failures_and_says_when_it_ended(tmp_path: Path) -> None:
    now = [0.0]
    progress = Progress(6, already=2, quiet=True, clock=lambda: now[0], file=tmp_path / PROGRESS_FILE)
    first = CampaignProgress.model_validate_json((tmp_path / PROGRESS_FILE).read_bytes())
    assert (first.state, first.done, first.total, first.eta_s) == ("running", 2, 6, None)  # written at the start
    now[0] = 1.0
    progress.advance(2, "gen-1", ["yolo", "rules"], failed=["rules"])
    now[0] = 2.0
    progress.advance(2, "gen-2", ["yolo", "rules"])
    written = CampaignProgress.model_validate_json((tmp_path / PROGRESS_FILE).read_bytes())
    assert (written.done, written.failed, written.last) == (6, 1, "gen-2")
    assert written.systems == {"yolo": SystemProgress(done=2, failed=0, rate_per_s=1.0),
                               "rules": SystemProgress(done=2, failed=1, rate_per_s=1.0)}  # fmt: skip
    assert written.rate_per_s == 2.0 and written.eta_s == 0.0
    progress.finish()
    assert CampaignProgress.model_validate_json((tmp_path / PROGRESS_FILE).read_bytes()).state == "ended"


def test_a_resumed_campaign_counts_what_its_earlier_runs_finished_but_not_in_its_rates(tmp_path: Path) -> None:
    now = [0.0]
    progress = Progress(6, already=3, quiet=True, clock=lambda: now[0], file=tmp_path / PROGRESS_FILE)
    progress.earlier(["yolo", "yolo", "rules"], failed=["rules"])
    now[0] = 2.0
    progress.advance(1, "gen-3", ["rules"])
    written = CampaignProgress.model_validate_json((tmp_path / PROGRESS_FILE).read_bytes())
    assert (written.done, written.failed, written.rate_per_s) == (4, 1, 0.5)
    assert written.systems == {"yolo": SystemProgress(done=2, failed=0, rate_per_s=0.0),
                               "rules": SystemProgress(done=2, failed=1, rate_per_s=0.5)}  # fmt: skip


def test_the_console_lists_campaigns_their_state_and_a_broken_file_as_an_error(tmp_path: Path) -> None:
    progress_file(tmp_path / "c-running")
    progress_file(tmp_path / "c-done", state="ended", done=8, updated_at=time.time() - 5)
    progress_file(tmp_path / "c-stopped", state="ended", done=3, updated_at=time.time() - 6)
    progress_file(tmp_path / "c-killed", updated_at=time.time() - STALLED_S - 1)
    (tmp_path / "c-garbage").mkdir()
    (tmp_path / "c-garbage" / PROGRESS_FILE).write_text('{"campaign": "x", "total": -1', encoding="utf-8")
    (tmp_path / "c-wrong").mkdir()
    (tmp_path / "c-wrong" / PROGRESS_FILE).write_text('{"campaign": "x", "total": "many"}', encoding="utf-8")
    (tmp_path / "c-huge").mkdir()
    (tmp_path / "c-huge" / PROGRESS_FILE).write_bytes(b" " * 1_000_001)
    (tmp_path / "not-a-campaign").mkdir()
    listed = {c["campaign"]: c for c in list_campaigns(tmp_path)}
    assert {name: c.get("state") for name, c in listed.items()} == {
        "c-running": "running", "c-done": "completed", "c-stopped": "stopped", "c-killed": "stalled",
        "c-garbage": None, "c-wrong": None, "c-huge": None,
    }  # fmt: skip
    assert "progress.json" in listed["c-garbage"]["error"] and "larger than" in listed["c-huge"]["error"]
    assert list_campaigns(tmp_path)[0]["campaign"] == "c-running"  # the newest first


@pytest.mark.timeout(180)
def test_a_tiny_campaign_reports_its_progress_live_and_the_console_shows_it_done(tmp_path: Path) -> None:
    out = tmp_path / "runs" / "campaign-tiny"
    plan = CampaignPlan(
        scenes=[generate_scene(300 + i, persons=60, casualties=i % 2, scene_id=f"tiny-{i + 1}") for i in range(2)],
        systems=parse_systems("yolo,rules", environ={}), settings=EpisodeSettings(frames=FRAMES),
    )  # fmt: skip
    seen: list[tuple[str, int]] = []
    over = threading.Event()

    def watch() -> None:  # what a console polling the file sees while the campaign runs
        while not over.is_set():
            try:
                state = CampaignProgress.model_validate_json((out / PROGRESS_FILE).read_bytes())
            except (OSError, ValueError):
                continue
            if not seen or seen[-1] != (state.state, state.done):
                seen.append((state.state, state.done))

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        run_campaign(plan, out, quiet=True)
    finally:
        over.set()
        watcher.join(5.0)
    final = CampaignProgress.model_validate_json((out / PROGRESS_FILE).read_bytes())  # a busy watcher may miss it
    if not seen or seen[-1] != (final.state, final.done):
        seen.append((final.state, final.done))
    assert seen[0] == ("running", 0) and seen[-1] == ("ended", 4), seen
    with ConsoleServer(tmp_path / "runs", port=0) as server:
        answer = httpx.get(f"http://127.0.0.1:{server.port}/api/campaigns",
                           headers={"authorization": f"Bearer {server.token}"})  # fmt: skip
        refused = httpx.get(f"http://127.0.0.1:{server.port}/api/campaigns")
    (shown,) = answer.json()["campaigns"]
    assert refused.status_code == 403
    assert (shown["campaign"], shown["state"], shown["done"], shown["total"]) == ("campaign-tiny", "completed", 4, 4)
    assert set(shown["systems"]) == {"yolo", "rules"} and all(s["done"] == 2 for s in shown["systems"].values())


@pytest.mark.timeout(60)
def test_the_page_follows_a_campaign_as_its_progress_changes(browser: Any, tmp_path: Path) -> None:
    path = progress_file(tmp_path / "campaign-a", done=1, total=4, rate_per_s=0.5, eta_s=6.0,
                         systems={"yolo": {"done": 1, "rate_per_s": 0.5}})  # fmt: skip
    with ConsoleServer(tmp_path, port=0) as server:
        page = browser.new_page()
        page.goto(server.url)
        box = page.locator("#campaigns")
        box.locator("text=1/4 records").wait_for(timeout=20_000)
        assert "ETA 0:00:06" in box.inner_text() and "yolo 1, 0.50/s" in box.inner_text()
        data = json.loads(path.read_text())
        data.update(done=4, failed=1, state="ended", updated_at=time.time())
        path.write_text(json.dumps(data), encoding="utf-8")  # the campaign goes on in its own process
        box.locator("text=4/4 records").wait_for(timeout=20_000)
        assert "completed" in box.inner_text() and "1 failed" in box.inner_text()
        page.close()
