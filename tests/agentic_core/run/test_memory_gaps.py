"""Two gaps of the run's memory closed: what a run found is written as it happens, so ``kill -9`` does not lose
it; and a mission that declares ``knowledge:`` flown without ``--memory`` says that nothing is looked up."""

from __future__ import annotations

import contextlib
import json
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from agentic_core.agent.bus import EventBus
from agentic_core.contracts.events import RunEvent
from agentic_core.memory.fleet import FleetMemory
from agentic_core.run.run_memory import RunMemory, start_memory
from tests.waiting import wait_for

REPO = Path(__file__).resolve().parents[3]
PATROL = REPO / "missions" / "hajj_patrol.yaml"
NORMAL = REPO / "tests" / "agentic_core" / "run" / "scenes" / "small_normal.yaml"


def test_a_memory_is_written_when_its_event_is_seen_not_at_the_end(tmp_path: Path) -> None:
    run = RunMemory(tmp_path / "m.db", "R1", view=dict, locate=lambda o: None, mission="m", scene="s")
    run.recorder.on_event(RunEvent(kind="tool", seq=4, name="incidents.log", status="ok",
                                   args={"kind": "crowd", "description": "west gate busy"}))  # fmt: skip
    other = FleetMemory(tmp_path / "m.db", embed=False)  # another connection sees it at once: committed
    assert other.store.get(("memory", "incident"), "R1:4") is not None
    other.close()
    bus, seen = EventBus(), list[RunEvent]()
    bus.subscribe(seen.append)
    run.finish(bus)
    assert seen[-1].fields()["memories"] == ["incident/R1:4"]  # said once, written once


def test_knowledge_without_memory_is_said_in_the_trace() -> None:
    bus, seen = EventBus(), list[RunEvent]()
    bus.subscribe(seen.append)
    start_memory(None, ["heat stroke triage"], bus, lambda: None)
    (event,) = seen
    f = event.fields()
    assert event.kind == "log" and f["level"] == "warning" and f["topics"] == ["heat stroke triage"]
    assert "without --memory nothing is looked up" in (event.summary or "")
    start_memory(None, [], bus, lambda: None)  # nothing declared: nothing to say
    assert len(seen) == 1


def trace(folder: Path) -> list[dict[str, Any]]:
    out = []
    for line in (folder / "trace.jsonl").read_text(encoding="utf-8").splitlines():
        with contextlib.suppress(json.JSONDecodeError):  # a line cut by the kill
            out.append(json.loads(line))
    return out


def logged_then_more(runs: Path) -> tuple[Path, int] | None:
    """The run folder and the seq of its first incident logged, once a later event shows it was handled."""
    folders = [p for p in runs.iterdir() if p.is_dir()] if runs.exists() else []
    if not folders or not (folders[0] / "trace.jsonl").is_file():
        return None
    records = trace(folders[0])
    logged = [r["seq"] for r in records if r["kind"] == "tool" and r.get("name") == "incidents.log"
              and r.get("status") == "ok"]  # fmt: skip
    if logged and any(r["seq"] > logged[0] for r in records):  # subscribers run in order, under the bus's lock
        return folders[0], logged[0]
    return None


@pytest.mark.slow
def test_a_run_killed_with_kill_9_keeps_the_memories_of_what_it_found_before(tmp_path: Path) -> None:
    runs, memory = tmp_path / "runs", tmp_path / "memory.db"
    cmd = [sys.executable, "-m", "agentic_core", "run", str(PATROL), "--scene", str(NORMAL), "--runs-dir", str(runs),
           "--memory", str(memory), "--param", "rounds=1", "--camera-hz", "2", "--gcs", "none"]  # fmt: skip
    proc = subprocess.Popen(cmd, cwd=REPO, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)  # fmt: skip
    try:
        found = wait_for(lambda: logged_then_more(runs), timeout_s=240.0, what="an incident logged")
        assert found is not None
        folder, seq = found
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10.0)
    assert proc.returncode == -signal.SIGKILL
    assert not any(r["kind"] == "memory" and r.get("event") == "recorded" for r in trace(folder))  # never ended
    fleet = FleetMemory(memory, embed=False)
    item = fleet.store.get(("memory", "incident"), f"{folder.name}:{seq}")
    fleet.close()
    assert item is not None and item.value["provenance"]["run_id"] == folder.name
