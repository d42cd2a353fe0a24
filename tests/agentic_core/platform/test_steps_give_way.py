"""A step that calls no tool the dispatcher could interrupt — a ``wait_until`` whose condition never comes true —
still gives way to a stop: the wall-clock limit (``--max-wall-s``) and a signal both end the run, in bounded time,
with the aircraft brought home and the outcome saying it was interrupted. Before, the wait went on forever: the
limit was read only between supersteps, and a signal's abort only by flight actions."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from agentic_core.run.runner import MissionRun, RunSettings
from tests.waiting import wait_for

from .conftest import REPO, of_kind, tools_ok, trace

pytestmark = pytest.mark.timeout(180)

NEVER = """
plan_id: wait_forever
goal: wait in the air for something that never happens
limits:
  geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 100}
  max_altitude_m: 25
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: wait, action: wait_until, depends_on: [up], condition: "vehicle.battery_pct > 200", poll_s: 0.2}
  - {id: home, action: rtl, depends_on: [wait]}
"""


def mission(tmp_path: Path) -> Path:
    path = tmp_path / "wait_forever.yaml"
    path.write_text(NEVER, encoding="utf-8")
    return path


def brought_home(run_dir: Path) -> None:
    records = trace(run_dir)
    assert tools_ok(records, "flight.rtl"), "the aircraft was not brought home"
    assert not [s for s in of_kind(records, "step") if s["step"] == "home"], "the mission's own rtl step ran"
    end = next(r for r in of_kind(records, "run") if r.get("event") == "end")
    assert end["outcome"] == "interrupted" and "on the ground" in end["ended"], end


def test_the_wall_clock_limit_ends_a_wait_that_never_comes_true(tmp_path: Path) -> None:
    settings = RunSettings(mission=mission(tmp_path), runs_dir=tmp_path / "runs", camera_hz=2.0, max_wall_s=4.0)
    start = time.monotonic()
    result = MissionRun(settings, progress=None).execute()
    assert result.summary.outcome == "interrupted", result.summary
    assert time.monotonic() - start < 90.0
    logged = [r.get("summary") for r in of_kind(trace(result.run_dir), "log")]
    assert "over 4 s of wall time: RTL" in logged, logged
    brought_home(result.run_dir)


def test_a_signal_ends_a_wait_that_never_comes_true(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    output = tmp_path / "run.out"
    argv = [sys.executable, "-m", "agentic_core", "run", str(mission(tmp_path)), "--runs-dir", str(runs),
            "--camera-hz", "2", "--gcs", "none"]  # fmt: skip
    with output.open("w", encoding="utf-8") as sink:
        proc = subprocess.Popen(argv, cwd=REPO, stdout=sink, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    try:

        def waiting() -> bool:
            assert proc.poll() is None, f"the run ended first ({proc.returncode}): {output.read_text()[-2000:]}"
            traces = [p / "trace.jsonl" for p in runs.iterdir()] if runs.is_dir() else []
            return any(t.is_file() and tools_ok(trace(t.parent), "flight.takeoff") for t in traces)

        wait_for(waiting, timeout_s=90.0, what="the take-off before the endless wait")
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=90.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10.0)
    said = output.read_text(encoding="utf-8")
    assert code == 1, said[-2000:]
    assert "stopped at once" not in said, "one signal should have been enough"
    (folder,) = [p for p in runs.iterdir() if p.is_dir()]
    brought_home(folder)
