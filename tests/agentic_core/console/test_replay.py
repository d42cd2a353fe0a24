"""Replaying runs: the console lists each run of ``--runs-dir`` with its outcome (``running`` until its end event,
a line cut by a kill skipped), opens one's events and telemetry, and in the browser the time slider moves the
aircraft and the timeline through the flight."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from agentic_core.console import ConsoleServer
from agentic_core.console.runs import TELEMETRY_POINTS, list_runs, replay
from agentic_core.contracts.errors import InputError

HOME = (21.4133, 39.8933)
HOSTILE = '<img src="http://203.0.113.7/x.png" onerror="window.pwned = 1"><script>window.pwned = 2</script>'


def write_run(runs: Path, run_id: str, *, ended: bool, samples: int = 40) -> Path:
    folder = runs / run_id
    folder.mkdir(parents=True)
    events: list[dict[str, Any]] = [{"kind": "run", "seq": 1, "sim_t": 0.0, "event": "start", "mission": "m.yaml",
                                     "summary": "start"}]  # fmt: skip
    events += [{"kind": "tool", "seq": 1 + i, "sim_t": float(i * 10), "name": "flight.fly_to", "status": "ok",
                "summary": f"leg {i}"} for i in range(1, 4)]  # fmt: skip
    events.append({"kind": "log", "seq": 5, "sim_t": 35.0, "summary": HOSTILE})  # text a model or a file wrote
    if ended:
        events.append({"kind": "run", "seq": 9, "sim_t": 39.0, "event": "end", "outcome": "completed",
                       "summary": "end"})  # fmt: skip
    lines = [json.dumps(e) for e in events] + ['{"kind": "log", "seq": 10, "summ']  # the last line cut by a kill
    (folder / "trace.jsonl").write_text("\n".join(lines), encoding="utf-8")
    telemetry = [{"time_s": float(t), "lat_deg": HOME[0] + t * 1e-5, "lon_deg": HOME[1], "alt_m": 30.0,
                  "north_m": t * 1.1, "east_m": 0.0, "yaw_deg": 0.0} for t in range(samples)]  # fmt: skip
    (folder / "telemetry.jsonl").write_text("\n".join(json.dumps(t) for t in telemetry), encoding="utf-8")
    return folder


def test_runs_are_listed_newest_first_with_their_outcome(tmp_path: Path) -> None:
    write_run(tmp_path, "20260101-000000-a", ended=True)
    write_run(tmp_path, "20260102-000000-b", ended=False)
    (tmp_path / "not-a-run").mkdir()
    listed = list_runs(tmp_path)
    assert [(r["id"], r["outcome"]) for r in listed] == [("20260102-000000-b", "running"),
                                                          ("20260101-000000-a", "completed")]  # fmt: skip
    assert listed[1]["sim_s"] == 39.0 and listed[1]["events"] == 6


def test_a_replay_has_the_events_and_a_thinned_flight(tmp_path: Path) -> None:
    write_run(tmp_path, "r1", ended=True, samples=TELEMETRY_POINTS * 3)
    opened = replay(tmp_path, "r1")
    assert len(opened["events"]) == 6 and "mission" not in opened  # no run.json: no map, the flight still shows
    assert TELEMETRY_POINTS <= len(opened["telemetry"]) <= TELEMETRY_POINTS + 1
    assert opened["telemetry"][-1]["time_s"] == TELEMETRY_POINTS * 3 - 1  # the end of the flight is kept
    with pytest.raises(InputError, match="no run"):
        replay(tmp_path, "../r1")


@pytest.mark.timeout(60)
def test_the_time_slider_moves_through_a_finished_run_and_shows_hostile_text_as_text(
    browser: Any, tmp_path: Path
) -> None:
    write_run(tmp_path, "20260101-000000-a", ended=True)
    with ConsoleServer(tmp_path, port=0) as server:
        page = browser.new_page()
        requested: list[str] = []
        page.on("request", lambda request: requested.append(request.url))
        page.goto(server.url)
        page.locator("#slider").wait_for(state="visible", timeout=20_000)
        page.wait_for_function("() => window.consoleState.events.length === 6", timeout=20_000)
        assert page.locator("#timeline").inner_text().count("<img src=") == 1  # shown as text, never as HTML
        found = page.evaluate("() => [window.pwned, document.querySelectorAll('#timeline img, script').length]")
        assert found == [None, 3]  # nothing ran, and no element was made: the page's own three scripts only
        at_end = page.evaluate("() => window.consoleState.lastSample.time_s")
        page.evaluate("() => { const s = document.getElementById('slider'); s.value = 15; s.dispatchEvent("
                      "new Event('input')); }")  # fmt: skip
        shown = page.evaluate("() => window.consoleState.events.map(e => e.summary)")
        assert at_end == 39.0 and shown == ["start", "leg 1"]
        assert page.evaluate("() => window.consoleState.lastSample.time_s") == 15.0
        assert page.locator("#controls").is_hidden()  # nothing to steer in a replay
        page.close()
    own = f"http://127.0.0.1:{server.port}/"
    assert requested and all(url.startswith(own) for url in requested)


@pytest.mark.timeout(60)
def test_a_run_flying_in_another_process_is_followed_from_its_files(browser: Any, tmp_path: Path) -> None:
    folder = write_run(tmp_path, "20260101-000000-a", ended=False, samples=10)
    with ConsoleServer(tmp_path, port=0) as server:
        page = browser.new_page()
        page.goto(server.url)
        page.wait_for_function("() => window.consoleState.lastSample && window.consoleState.lastSample.time_s === 9")
        assert "running elsewhere" in page.locator("#status").inner_text()
        with (folder / "telemetry.jsonl").open("a", encoding="utf-8") as more:  # the other process flies on
            more.write("\n" + json.dumps({"time_s": 30.0, "lat_deg": HOME[0], "lon_deg": HOME[1], "alt_m": 0.0}))
        with (folder / "trace.jsonl").open("a", encoding="utf-8") as more:
            more.write(
                "\n" + json.dumps({"kind": "run", "seq": 11, "sim_t": 30.0, "event": "end", "outcome": "completed"})
            )
        page.wait_for_function("() => window.consoleState.lastSample.time_s === 30", timeout=20_000)
        page.wait_for_function("() => document.getElementById('status').textContent.endsWith('replay')", timeout=20_000)
        page.close()
