"""The control port steers a real run from another thread: a pause holds the aircraft where it is until resume
(and the mission then goes on to its end), an abort ends the mission in the air with the aircraft holding, and
every command is a ``control`` event naming who sent it."""

from __future__ import annotations

import contextlib
import gc
import math
import os
from pathlib import Path

import pytest

from agentic_core.graph.checkpoint.sqlite import SqliteSaver
from agentic_core.run.fork import CHECKPOINTS_FILE, fork_run
from agentic_core.run.runner import MissionRun, RunSettings, resume_run
from tests.waiting import wait_for

from .conftest import REPO, fly_steered, of_kind, pause_and_hold, telemetry, trace

PATROL = REPO / "missions" / "hajj_patrol.yaml"
NORMAL = REPO / "tests" / "agentic_core" / "run" / "scenes" / "small_normal.yaml"


def patrol(tmp_path: Path, *, approved: bool = False) -> MissionRun:
    """The patrol mission; ``approved``: its patrol (a repeat) asks for approval first, answered by the policy."""
    mission = PATROL
    if approved:
        mission = tmp_path / "patrol.yaml"
        text = PATROL.read_text(encoding="utf-8")
        mission.write_text(text.replace("    action: repeat\n", "    action: repeat\n    approval: true\n", 1))
    settings = RunSettings(mission=mission, scene=NORMAL, runs_dir=tmp_path / "runs", params={"rounds": "1"},
                           camera_hz=5.0)  # fmt: skip
    return MissionRun(settings)


def open_files() -> list[str]:
    """What this process holds open, by path."""
    paths = []
    for fd in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):  # the listing's own descriptor is gone by now
            paths.append(os.readlink(f"/proc/self/fd/{fd}"))
    return paths


def flying_a_leg(run: MissionRun) -> bool:
    sample = run.last_sample
    return sample is not None and sample.alt_m > 30.0 and math.hypot(sample.vn_mps, sample.ve_mps) > 3.0


@pytest.mark.slow
def test_a_pause_holds_the_aircraft_until_resume_and_the_mission_then_completes(tmp_path: Path) -> None:
    """The paused step (the patrol, approved before it started) flies again after resume without being asked
    again, with the approval kept; a fork of the run from a checkpoint that keeps it asks again."""
    run = patrol(tmp_path, approved=True)
    held: list[tuple[float, float]] = []

    result = fly_steered(run, pause_and_hold(run, lambda: flying_a_leg(run), "the first leg", 10.0, held))
    assert held, "the operator thread never resumed"
    assert result.summary.outcome == "completed"
    start, end = held[0]
    during = [t for t in telemetry(result.run_dir) if start <= t["time_s"] <= end]
    assert during and max(t["north_m"] for t in during) - min(t["north_m"] for t in during) < 1.0
    assert max(math.hypot(t["vn_mps"], t["ve_mps"]) for t in during) < 0.5
    records = trace(result.run_dir)
    commands = [(r["command"], r["by"]) for r in of_kind(records, "control")]
    assert commands == [("pause", "tester"), ("resume", "tester")]
    stopped = [r for r in of_kind(records, "tool") if r.get("status") == "interrupted"]
    assert stopped and "paused" in stopped[0]["summary"]
    flown = [r["name"] for r in of_kind(records, "tool") if r.get("status") == "ok"]
    assert flown.count("incidents.log") == 2 and flown[-1] == "flight.rtl"  # the whole pass was flown after all
    assert [r["request"]["step"] for r in of_kind(records, "approval")] == ["patrol"]  # asked once, not after resume
    (interrupted,) = [r for r in of_kind(records, "mission") if r.get("status") == "interrupted"]
    assert interrupted["step"] == "patrol" and interrupted["approval"] == "kept"

    # A fork from a checkpoint that keeps the approval is a new run: its operator is asked again.
    saver = SqliteSaver(result.run_dir / CHECKPOINTS_FILE)
    try:
        kept = [c for c in saver.list(result.run_id) if (c.values.get("approved") or {}).get("patrol") is not None]
    finally:
        saver.close()
    assert kept, "no checkpoint keeps the approval"
    runs = result.run_dir.parent
    fork = resume_run(runs, fork_run(runs, result.run_id, kept[-1].id), progress=None, approval="approve")
    assert fork.summary.outcome == "completed"
    after = trace(fork.run_dir)
    start = next(k for k, r in enumerate(after) if r.get("event") == "fork")
    assert [r["request"]["step"] for r in of_kind(after[start:], "approval")] == ["patrol"]  # before: none
    gc.collect()  # what is still open now, something holds
    assert not [f for f in open_files() if f.startswith(str(runs))]  # before: both runs' audit.jsonl


@pytest.mark.slow
@pytest.mark.parametrize("on_abort", [None, "hold", "land"])
def test_an_abort_from_another_thread_does_what_the_mission_says(tmp_path: Path, on_abort: str | None) -> None:
    """The operator's abort ends the mission; the aircraft then does the mission's ``on_abort``: return home by
    default, or hold, or land where it is — and the trace and the report say where it ended."""
    mission = tmp_path / "patrol.yaml"
    mission.write_text(PATROL.read_text(encoding="utf-8") + (f"\non_abort: {on_abort}\n" if on_abort else ""))
    settings = RunSettings(mission=mission, scene=NORMAL, runs_dir=tmp_path / "runs", params={"rounds": "1"},
                           camera_hz=5.0)  # fmt: skip
    run = MissionRun(settings)

    def operator() -> None:
        wait_for(lambda: flying_a_leg(run), timeout_s=120.0, what="the first leg")
        run.control.abort("the operator saw smoke", by="tester")

    result = fly_steered(run, operator)
    assert result.summary.outcome == "aborted"
    records = trace(result.run_dir)
    (command,) = of_kind(records, "control")
    assert command["command"] == "abort" and command["reason"] == "the operator saw smoke"
    last = telemetry(result.run_dir)[-1]
    done = [r["name"] for r in of_kind(records, "tool") if r.get("status") == "ok"]
    end = next(r for r in of_kind(records, "run") if r.get("event") == "end")
    if on_abort == "hold":
        assert last["alt_m"] > 20.0 and last["mode"] == "hold" and "in the air" in end["ended"]
    elif on_abort == "land":
        assert done[-1] == "flight.land" and "flight.rtl" not in done and last["alt_m"] < 0.5
        assert end["ended"].startswith("on the ground")
    else:
        assert done[-1] == "flight.rtl" and last["alt_m"] < 0.5 and math.hypot(last["north_m"], last["east_m"]) < 3
        assert end["ended"].startswith("on the ground")
    assert f"The aircraft ended {end['ended']}." in (result.run_dir / "report.md").read_text(encoding="utf-8")
