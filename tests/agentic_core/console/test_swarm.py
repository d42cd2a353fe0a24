"""A swarm run in the console: listed as one entry of kind ``swarm`` (its UAVs, outcome, closest separation) and
not as its UAVs' runs; opened with every UAV's flight, the sectors and their awards, the casualty, and one timeline
of every UAV's events and the swarm's, each tagged with its UAV. Hostile: a missing, torn or huge file, or a UAV
folder named to climb out of the swarm's, is shown as an error or left out, never a crash, and reading stays
bounded. In the browser, every UAV's marker and the award in the timeline, and the slider moves every vehicle."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import httpx
import pytest

from agentic_core.console import ConsoleServer
from agentic_core.console.reading import read_jsonl
from agentic_core.console.swarms import list_swarms, replay_swarm, uav_folders
from agentic_core.contracts.errors import InputError
from agentic_core.contracts.swarm import Rejection

REPO = Path(__file__).resolve().parents[3]
HOME = (21.4133, 39.8933)
SWARM = "20260301-100000-hajj_swarm-swarm"
SAMPLES = 60
CORNERS = ((0, -1), (1, -1), (1, 1), (0, 1))


def uav_run(swarm: Path, n: int, *, ended: bool = True) -> Path:
    """One UAV's run folder as a swarm run writes it: run.json, trace.jsonl, telemetry.jsonl (a leg north, its
    own pad east of home)."""
    folder = swarm / f"20260301-10000{n}-uav-{n}-rules"
    folder.mkdir(parents=True)
    mission, scene = REPO / "missions" / "hajj_swarm.yaml", REPO / "scenes" / "hajj_swarm.yaml"
    settings = {"mission": str(mission), "scene": str(scene), "reasoner": "rules", "runs_dir": str(swarm)}
    (folder / "run.json").write_text(json.dumps({"run_id": folder.name, "settings": settings}), encoding="utf-8")
    t0 = time.time()
    events: list[dict[str, Any]] = [
        {"kind": "run", "seq": 1, "t": t0, "sim_t": 0.02, "summary": f"start uav-{n}", "event": "start",
         "mission": str(swarm / "missions" / f"uav-{n}.yaml"), "reasoner": "rules", "backend": "sim"},
        {"kind": "tool", "seq": 2, "t": t0 + 1, "sim_t": 12.0, "summary": "flight.takeoff ok", "name": "flight.takeoff",
         "args": {"altitude_m": 30.0}, "status": "ok", "error": None},
    ]  # fmt: skip
    if ended:
        events.append({"kind": "run", "seq": 3, "t": t0 + 5, "sim_t": SAMPLES - 1.0, "summary": "end: completed",
                       "event": "end", "outcome": "completed"})  # fmt: skip
    (folder / "trace.jsonl").write_text("".join(json.dumps(e) + "\n" for e in events), encoding="utf-8")
    east = (n - 2) * 30.0
    samples = [{"time_s": float(t), "lat_deg": HOME[0] + t * 1e-5, "lon_deg": HOME[1] + east * 9.7e-6,
                "alt_m": 30.0, "north_m": t * 1.1, "east_m": east, "yaw_deg": 0.0, "battery_pct": 100.0 - t / 10,
                "mode": "offboard", "armed": True, "landed_state": "in_air"} for t in range(SAMPLES)]  # fmt: skip
    (folder / "telemetry.jsonl").write_text("".join(json.dumps(s) + "\n" for s in samples), encoding="utf-8")
    return folder


def write_swarm(runs: Path, *, uavs: int = 3, finished: bool = True) -> Path:
    """A swarm run's directory in the format ``agentic-uav swarm run`` writes (swarm_run.py, swarm_outcome.py)."""
    swarm = runs / SWARM
    (swarm / "missions").mkdir(parents=True)
    folders = {f"uav-{n}": uav_run(swarm, n) for n in range(1, uavs + 1)}
    t0 = time.time()
    corners = {
        f"S{i}": [{"lat": HOME[0] + 0.0005 * (i + di), "lon": HOME[1] + 0.001 * de} for di, de in CORNERS]
        for i in range(1, uavs + 1)
    }
    awarded = {f"S{i}": f"uav-{uavs + 1 - i}" for i in range(1, uavs + 1)}
    log: list[dict[str, Any]] = [
        {"event": "round", "sim_t": 0.0, "t": t0, "task": f"survey:{s}", "bids": {u: 60.0 for u in folders},
         "silent": [], "awarded": w} for s, w in awarded.items()
    ]  # fmt: skip
    log += [
        {"event": "sectors", "sim_t": 0.0, "t": t0, "awarded": awarded, "sectors": corners},
        {"event": "claim", "sim_t": 20.0, "t": t0 + 2, "uav": "uav-2", "object": "P-09", "claimed": True,
         "casualty": "C1", "where": {"north": 110.0, "east": -30.0, "alt": 0.0}},
        {"event": "round", "sim_t": 21.0, "t": t0 + 2.1, "task": "verify_casualty:uav-2:C1",
         "bids": {"uav-1": 40.0}, "silent": [], "awarded": "uav-1"},
        {"event": "covered", "sim_t": 30.0, "t": t0 + 3, "uav": "uav-1", "sector": "S3", "surveys": 1},
        {"event": "verify", "sim_t": 34.0, "t": t0 + 3.4, "uav": "uav-2", "casualty": "C1",
         "seen_by": ["uav-1", "uav-2"], "k": 2, "verified": True},
        {"event": "round", "sim_t": 35.0, "t": t0 + 3.5, "task": "deliver_kit:uav-2:C1",
         "bids": {"uav-3": 50.0}, "silent": [], "awarded": "uav-3"},
        {"event": "delivered", "sim_t": 50.0, "t": t0 + 5, "uav": "uav-3", "casualty": "C1"},
    ]  # fmt: skip
    (swarm / "swarm.jsonl").write_text("".join(json.dumps(r) + "\n" for r in log), encoding="utf-8")
    refused = Rejection(at=t0 + 3.45, receiver="uav-3", reason="replayed", sender="ground", kind="award", nonce="n1")
    (swarm / "refusals.jsonl").write_text(refused.model_dump_json() + "\n", encoding="utf-8")
    if finished:
        summary = {
            "swarm_id": SWARM, "mission": "missions/hajj_swarm.yaml", "vehicles": uavs, "outcome": "completed",
            "exit": 0, "problems": [], "lost": [],
            "uavs": {u: {"outcome": "completed", "error": None, "run_dir": str(f), "role": "scout", "system_id": i + 1,
                         "sim_s": SAMPLES - 1.0} for i, (u, f) in enumerate(folders.items())},
            "sectors": {s: [w] for s, w in awarded.items()},
            "separation": {"min_distance_m": 19.05, "closest": ["uav-1", "uav-2"], "at_s": 40.0, "losses": 0,
                           "horizontal_m": 15.0, "vertical_m": 8.0, "instants": 100},
            "sim_s": SAMPLES - 1.0,
        }  # fmt: skip
        (swarm / "summary.json").write_text(json.dumps(summary, indent=2), encoding="utf-8")
    return swarm


def test_a_swarm_is_one_entry_with_its_uavs_outcome_and_closest_separation(tmp_path: Path) -> None:
    write_swarm(tmp_path)
    (listed,) = list_swarms(tmp_path)
    assert (listed["id"], listed["kind"], listed["outcome"], listed["vehicles"]) == (SWARM, "swarm", "completed", 3)
    assert listed["min_separation_m"] == 19.05 and "error" not in listed
    assert [u["uav"] for u in listed["uavs"]] == ["uav-1", "uav-2", "uav-3"]
    with ConsoleServer(tmp_path, port=0) as server:
        runs = httpx.get(f"{server.url.split('#')[0]}api/runs", headers={"authorization": f"Bearer {server.token}"})
    assert [(r["id"], r["kind"]) for r in runs.json()["runs"]] == [(SWARM, "swarm")]  # its UAVs' runs are under it


def test_a_swarm_opens_with_every_uav_the_sectors_awards_casualty_and_one_tagged_timeline(tmp_path: Path) -> None:
    write_swarm(tmp_path)
    opened = replay_swarm(tmp_path, SWARM)
    assert [(v["uav"], v["outcome"], len(v["telemetry"])) for v in opened["vehicles"]] == [
        ("uav-1", "completed", SAMPLES), ("uav-2", "completed", SAMPLES), ("uav-3", "completed", SAMPLES)]  # fmt: skip
    assert {s["id"]: s["awarded"] for s in opened["sectors"]} == {"S1": "uav-3", "S2": "uav-2", "S3": "uav-1"}
    assert all(len(s["polygon"]) == 4 for s in opened["sectors"])
    (casualty,) = opened["casualties"]
    assert (casualty["found_by"], casualty["verified"], casualty["delivery_awarded"], casualty["delivered"]) == (
        "uav-2", True, "uav-3", True)  # fmt: skip
    assert casualty["at"][0] > HOME[0]  # 110 m north of the scene's home
    assert opened["scene"]["home"] and opened["mission"]["geofence"] and opened["mission"]["legs"] == []
    events = opened["events"]
    assert [e["sim_t"] for e in events] == sorted(e["sim_t"] for e in events)
    assert {e["uav"] for e in events if e["kind"] == "run"} == {"uav-1", "uav-2", "uav-3"}
    award = next(e for e in events if e["kind"] == "swarm" and "deliver_kit" in e["summary"])
    assert award["uav"] == "uav-3" and "award deliver_kit:uav-2:C1 to uav-3" in award["summary"]
    refused = next(e for e in events if e.get("event") == "refused")
    assert refused["uav"] == "uav-3" and "replayed" in refused["summary"] and refused["sim_t"] == 34.0
    assert opened["problems"] == []


def test_a_running_swarm_is_followed_from_its_files(tmp_path: Path) -> None:
    swarm = write_swarm(tmp_path, finished=False)
    (listed,) = list_swarms(tmp_path)
    assert listed["outcome"] == "running" and "error" not in listed and listed["vehicles"] == 3
    with (swarm / "swarm.jsonl").open("a", encoding="utf-8") as log:
        log.write('{"event": "covered", "sim_t": 55.0, "uav": "uav-2", "sec')  # being written as we read
    opened = replay_swarm(tmp_path, SWARM)
    assert opened["outcome"] == "running" and len(opened["vehicles"]) == 3 and opened["problems"] == []


def test_missing_torn_or_huge_files_are_errors_never_a_crash(tmp_path: Path) -> None:
    swarm = write_swarm(tmp_path)
    (swarm / "summary.json").write_text('{"outcome": "compl', encoding="utf-8")  # torn by a kill
    (listed,) = list_swarms(tmp_path)
    assert listed["outcome"] == "running" and "not JSON" in listed["error"]
    (swarm / "summary.json").write_bytes(b"[" + b" " * 1_000_001 + b"]")
    (listed,) = list_swarms(tmp_path)
    assert "larger than" in listed["error"] and len(listed["uavs"]) == 3
    (swarm / "summary.json").write_text("[1, 2]", encoding="utf-8")
    assert "not a JSON object" in list_swarms(tmp_path)[0]["error"]
    (swarm / "summary.json").unlink()
    (swarm / "swarm.jsonl").write_bytes(b'{"event": "x"' + b"0" * 17_000_000 + b"\n")  # huge and one line
    (swarm / "refusals.jsonl").write_bytes(b"\xff\xfe not json\n" * 10)
    for folder in swarm.glob("*-uav-2-*"):
        (folder / "telemetry.jsonl").unlink()
    started = time.monotonic()
    opened = replay_swarm(tmp_path, SWARM)
    assert time.monotonic() - started < 5.0
    assert opened["sectors"] == [] and [e for e in opened["events"] if e["kind"] == "swarm"] == []
    assert any("swarm.jsonl" in p for p in opened["problems"])
    assert [(v["uav"], len(v["telemetry"])) for v in opened["vehicles"]] == [("uav-1", SAMPLES), ("uav-2", 0),
                                                                           ("uav-3", SAMPLES)]  # fmt: skip
    with pytest.raises(InputError, match="no swarm run"):
        replay_swarm(tmp_path, "../" + SWARM)
    with pytest.raises(InputError, match="no swarm run"):
        replay_swarm(tmp_path, "not-there")


def test_reading_stays_bounded(tmp_path: Path) -> None:
    path = tmp_path / "telemetry.jsonl"
    path.write_text("".join(json.dumps({"time_s": float(t), "pad": "x" * 380}) + "\n" for t in range(20_000)))
    kept, problem = read_jsonl(path, 100_000_000, keep=500)
    assert problem is None and 400 <= len(kept) <= 1100 and kept[-1]["time_s"] == 19_999.0  # thinned, the end kept
    cut, problem = read_jsonl(path, 40_000)
    assert problem and "first 40000 bytes" in problem and len(cut) < 110


def test_a_uav_folder_outside_the_swarm_is_never_read(tmp_path: Path) -> None:
    swarm = write_swarm(tmp_path)
    outside = uav_run(tmp_path / "elsewhere", 9)
    summary = json.loads((swarm / "summary.json").read_text(encoding="utf-8"))
    summary["uavs"]["uav-2"]["run_dir"] = "../../elsewhere/" + outside.name  # only its last part is believed
    summary["uavs"]["../uav-7"] = {"run_dir": str(outside)}
    summary["uavs"]["uav-8"] = {"run_dir": ".."}
    (swarm / "summary.json").write_text(json.dumps(summary), encoding="utf-8")
    (swarm / "20260301-100009-uav-9-rules").symlink_to(outside, target_is_directory=True)  # a link out: not ours
    found = uav_folders(swarm, summary)
    assert sorted(found) == ["uav-1", "uav-2", "uav-3"]
    assert all(path.parent == swarm and not path.is_symlink() for path in found.values())
    opened = replay_swarm(tmp_path, SWARM)
    assert [v["uav"] for v in opened["vehicles"]] == ["uav-1", "uav-2", "uav-3"]


@pytest.mark.timeout(60)
def test_the_page_shows_every_uav_and_the_award_and_the_slider_moves_them_all(browser: Any, tmp_path: Path) -> None:
    write_swarm(tmp_path)
    with ConsoleServer(tmp_path, port=0) as server:
        page = browser.new_page()
        requested: list[str] = []
        page.on("request", lambda request: requested.append(request.url))
        page.goto(server.url)
        page.wait_for_function("() => window.consoleState.swarm && window.consoleState.events.length > 10",
                               timeout=20_000)  # fmt: skip
        labels = page.locator(".uav-marker .uav-label").all_inner_texts()
        assert sorted(labels) == ["uav-1", "uav-2", "uav-3"]
        timeline = page.locator("#timeline").inner_text()
        assert "award deliver_kit:uav-2:C1 to uav-3" in timeline and "replayed" in timeline
        award = page.locator("#timeline .ev.swarm", has_text="deliver_kit")
        assert award.first.get_attribute("data-uav") == "uav-3"
        assert page.locator("#swarm .uav-chip").count() == 3
        at_end = page.evaluate("() => Object.values(window.consoleState.swarmSamples).map(s => s.time_s)")
        page.evaluate("() => { const s = document.getElementById('slider'); s.value = 15; s.dispatchEvent("
                      "new Event('input')); }")  # fmt: skip
        moved = page.evaluate("() => Object.values(window.consoleState.swarmSamples).map(s => s.time_s)")
        shown = page.locator("#timeline").inner_text()
        assert at_end == [SAMPLES - 1.0] * 3 and moved == [15.0] * 3
        assert "deliver_kit" not in shown and "flight.takeoff" in shown and "start uav-3" in shown
        own = f"http://127.0.0.1:{server.port}/"
        assert requested and all(url.startswith(own) for url in requested)
