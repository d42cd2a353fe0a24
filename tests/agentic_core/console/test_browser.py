"""The console in a real browser (headless Chromium): the page loads with no request leaving 127.0.0.1, the live
run's events and the vehicle's position arrive, clicking Approve makes the emergency mission land beside the
casualty, and clicking Decline keeps the aircraft in the air (then the RTL button brings it home). The approve
test takes a screenshot mid-mission (an artefact in its tmp_path); with AGENTIC_UAV_UPDATE_SCREENSHOT=1 it also
writes the one the README shows, docs/console.png, which a plain test run leaves alone."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import pytest

from tests.waiting import wait_for

from ..platform.conftest import distance_to_casualty, of_kind, telemetry, tools_ok, trace
from .conftest import LiveRun

REPO = Path(__file__).resolve().parents[3]
SCREENSHOT = REPO / "docs" / "console.png"


def open_page(browser: Any, live: LiveRun) -> tuple[Any, list[str]]:
    """A page on the live console, every URL it requests recorded."""
    context = browser.new_context(viewport={"width": 1280, "height": 760})
    page = context.new_page()
    requested: list[str] = []
    page.on("request", lambda request: requested.append(request.url))
    live.thread.start()
    page.goto(live.server.url)
    return page, requested


def assert_stays_home(requested: list[str], live: LiveRun) -> None:
    own = f"http://127.0.0.1:{live.server.port}/"
    assert requested and all(url.startswith(own) for url in requested), [u for u in requested if not u.startswith(own)]


def answer(page: Any, button: str, reason: str | None = None) -> None:
    card = page.locator(".card").first
    card.wait_for(timeout=60_000)
    if reason:
        card.locator("input").fill(reason)
    card.locator(f"button.{button}").click()
    card.wait_for(state="detached", timeout=30_000)


@pytest.mark.slow
@pytest.mark.timeout(150)
def test_the_page_follows_the_run_and_approve_lands_it_beside_the_casualty(
    browser: Any, live_run: LiveRun, tmp_path: Path
) -> None:
    page, requested = open_page(browser, live_run)
    page.wait_for_function("() => window.consoleState && window.consoleState.received > 5", timeout=60_000)
    page.wait_for_function("() => window.consoleState.events.some(e => e.kind === 'tool')", timeout=60_000)
    seen = page.evaluate("window.consoleState.lastSample")
    run_sample = live_run.run.last_sample
    assert run_sample is not None and abs(seen["lat_deg"] - run_sample.lat_deg) < 0.01  # the vehicle is on the map
    page.locator(".card").first.wait_for(timeout=60_000)
    page.wait_for_function("() => window.consoleState.worlds.length > 0", timeout=30_000)
    shot = page.screenshot(path=str(tmp_path / "console.png"))  # mid-mission: over the casualty, the landing asked
    assert shot.startswith(b"\x89PNG") and len(shot) > 10_000
    if os.environ.get("AGENTIC_UAV_UPDATE_SCREENSHOT") == "1":
        SCREENSHOT.write_bytes(shot)
    answer(page, "approve")  # land beside them
    answer(page, "approve")  # release the kit
    result = live_run.finish()
    assert_stays_home(requested, live_run)
    records = trace(result.run_dir)
    console = [(r["command"], r["by"]) for r in of_kind(records, "control")]
    assert console == [("approve", "console"), ("approve", "console")]
    (landing,) = tools_ok(records, "flight.land")
    kit = tools_ok(records, "flight.deploy_payload")
    assert kit and landing["seq"] < kit[0]["seq"]
    assert distance_to_casualty(landing["result"] if "lat_deg" in (landing.get("result") or {}) else
                                _sample_at(result.run_dir, landing["sim_t"])) < 9.0  # fmt: skip


@pytest.mark.slow
@pytest.mark.timeout(150)
def test_decline_keeps_it_in_the_air_and_the_rtl_button_brings_it_home(browser: Any, live_run: LiveRun) -> None:
    page, requested = open_page(browser, live_run)
    answer(page, "decline", reason="too many people around")
    run = live_run.run
    declined_at = run.clock()
    wait_for(lambda: run.clock() > declined_at + 5.0, timeout_s=60.0, what="five seconds after the decline")
    sample = run.last_sample
    assert sample is not None and sample.alt_m > 5.0 and sample.landed_state == "in_air"
    page.locator("#controls button[data-command=rtl]").click()
    result = live_run.finish()
    assert_stays_home(requested, live_run)
    records = trace(result.run_dir)
    assert not tools_ok(records, "flight.land") and not tools_ok(records, "flight.deploy_payload")
    (declined,) = [r for r in of_kind(records, "approval") if r.get("answer") is False]
    assert declined["said"] == "too many people around"
    commands = [(r["command"], r["by"]) for r in of_kind(records, "control")]
    assert commands[0] == ("decline", "console") and ("rtl", "console") in commands
    last = telemetry(result.run_dir)[-1]  # home: the outcome is `degraded` only because no mail server is set
    assert last["alt_m"] < 0.5 and math.hypot(last["north_m"], last["east_m"]) < 3.0


def _sample_at(run_dir: Path, sim_t: float) -> dict[str, Any]:
    from ..platform.conftest import telemetry

    return min(telemetry(run_dir), key=lambda t: abs(t["time_s"] - sim_t))


def edit_and_approve(page: Any, edits: dict[str, Any], drop: tuple[str, ...] = ()) -> Any:
    """Open the first card's "edit arguments", change ``edits`` (and take out ``drop``) in its JSON, and click
    Approve."""
    card = page.locator(".card").first
    card.wait_for(timeout=60_000)
    if not card.locator("details").evaluate("details => details.open"):
        card.locator("summary").click()
    box = card.locator("textarea")
    edited = {k: v for k, v in json.loads(box.input_value()).items() if k not in drop}
    box.fill(json.dumps({**edited, **edits}))
    card.locator("button.approve").click()
    return card


@pytest.mark.slow
@pytest.mark.timeout(150)
def test_an_edited_argument_within_the_envelope_is_what_the_mission_flies(browser: Any, live_run: LiveRun) -> None:
    page, requested = open_page(browser, live_run)
    edit_and_approve(page, {"offset_m": 8}).wait_for(state="detached", timeout=30_000)
    page.wait_for_function(
        "() => window.consoleState.events.some(e => e.kind === 'tool' && e.name === 'flight.land' && e.status == 'ok')",
        timeout=60_000,
    )
    shown = page.evaluate("() => window.consoleState.events.find(e => e.kind === 'tool' && e.name === 'flight.land')")
    assert shown["args"]["offset_m"] == 8  # the page saw the mission act with the edited value
    answer(page, "approve")  # release the kit
    result = live_run.finish()
    assert_stays_home(requested, live_run)
    records = trace(result.run_dir)
    (edited,) = [r for r in of_kind(records, "approval") if r.get("edited")]
    assert edited["edited"] == {"offset_m": 8} and edited["request"]["args"]["offset_m"] == 5
    (landing,) = tools_ok(records, "flight.land")
    assert landing["args"]["offset_m"] == 8
    at = _sample_at(result.run_dir, landing["sim_t"])
    assert 5.0 < distance_to_casualty(at) < 12.0  # beside them, farther than the mission's own 5 m


@pytest.mark.slow
@pytest.mark.timeout(150)
def test_an_unknown_argument_or_an_edit_outside_the_envelope_is_refused_in_the_page(
    browser: Any, live_run: LiveRun
) -> None:
    page, requested = open_page(browser, live_run)
    card = edit_and_approve(page, {"offset_x": 3})
    card.locator(".why", has_text="refused").wait_for(timeout=10_000)
    assert "offset_x: not an argument of this step" in card.inner_text() and card.is_visible()  # still asked
    edit_and_approve(page, {"offset_m": 2000}, drop=("offset_x",)).wait_for(state="detached", timeout=30_000)
    page.wait_for_function(
        "() => window.consoleState.events.some(e => e.kind === 'tool' && e.name === 'flight.land' && e.status != 'ok')",
        timeout=60_000,
    )
    assert "geofence" in page.locator("#timeline").inner_text()  # 2 km off: the refusal, its reason, in the timeline
    result = live_run.finish()
    assert_stays_home(requested, live_run)
    records = trace(result.run_dir)
    assert not tools_ok(records, "flight.land") and not tools_ok(records, "flight.deploy_payload")
    (refused,) = [r for r in of_kind(records, "tool") if r.get("name") == "flight.land"]
    assert refused["status"] == "denied" and refused["args"]["offset_m"] == 2000
