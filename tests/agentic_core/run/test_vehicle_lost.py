"""A run's outcome is honest about the aircraft: a vehicle whose link went silent while it was in the air is
``lost`` (exit 1), never ``returned``; a return that errored, or an aircraft still in the air away from home, is not
``returned``. Flown for real: ``agentic-uav sim`` killed under a run mid-leg and during the mission's own return,
and the run ends ``lost`` within a bounded time (it waited 100 s before); unit cases for every rule."""

from __future__ import annotations

import json
import signal
import subprocess
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agentic_core.contracts import TelemetrySample
from agentic_core.run.cli import main as run_main
from agentic_core.run.vehicle_lost import LOST, judge
from tests.flight.test_cli import free_udp_port
from tests.flight.test_cli_vehicle import listening_port, start_sim
from tests.waiting import wait_for

LINK_LOSS_S = 10.0


def at(north: float, alt: float, *, landed: str = "in_air", armed: bool = True, mode: str = "hold") -> TelemetrySample:
    return TelemetrySample(time_s=30.0, lat_deg=21.4, lon_deg=39.9, alt_m=alt, north_m=north, east_m=0.0,
                           down_m=-alt, armed=armed, landed_state=landed, mode=mode)  # fmt: skip


def rtl(status: str, error: str | None = None) -> dict[str, Any]:
    return {"kind": "tool", "name": "flight.rtl", "status": status, "error": error}


AIR_AWAY, AIR_HOME, HOME_DOWN = at(44.2, 10.0), at(0.3, 3.9, mode="rtl"), at(0.3, 0.0, landed="on_ground", armed=False)
NO_ACK = "ToolError: rtl timeout: no COMMAND_ACK for NAV_RETURN_TO_LAUNCH after 3 attempt(s) of 1.5 s"


@pytest.mark.parametrize(
    ("outcome", "last", "records", "silent_s", "expected"),
    [
        # the tester's first case: the failsafe's return never heard, the aircraft last seen at 10 m, 44 m out
        ("returned", AIR_AWAY, [rtl("error", NO_ACK)], 14.6, LOST),
        # the second: killed during the mission's own return, last seen descending over home
        ("returned", AIR_HOME, [rtl("error", "the link is gone"), rtl("error", NO_ACK)], 15.2, LOST),
        ("completed", AIR_AWAY, [], 30.0, LOST),
        ("landed", AIR_AWAY, [], 11.0, LOST),
        ("held", AIR_AWAY, [], 11.0, LOST),
        ("degraded", AIR_AWAY, [], float("inf"), LOST),  # the link closed
        ("failed", AIR_AWAY, [], 30.0, "failed"),  # already a failure: kept, with a note
        ("interrupted", AIR_AWAY, [], 30.0, "interrupted"),  # a signal's stop stays resumable
        # the link alive, but the return errored, or the aircraft is still up away from home: not returned
        ("returned", AIR_AWAY, [rtl("error", "rtl denied")], 0.2, "failed"),
        ("returned", HOME_DOWN, [rtl("ok"), rtl("error", "rtl denied")], 0.2, "failed"),
        ("returned", AIR_AWAY, [rtl("ok")], 0.2, "failed"),
        # as the run says: home and down; a link back after a silence (SIGSTOP); down away from home after a
        # stop's landing in place; a mission that ends in the air with its link alive; on the ground, link gone
        ("returned", HOME_DOWN, [rtl("error", NO_ACK), rtl("ok")], 0.2, "returned"),
        ("returned", HOME_DOWN, [rtl("ok")], 0.1, "returned"),
        ("returned", at(40.0, 0.0, landed="on_ground", armed=False), [], 0.1, "returned"),
        ("completed", AIR_AWAY, [], 0.3, "completed"),
        ("completed", HOME_DOWN, [], 60.0, "completed"),
        ("aborted", AIR_AWAY, [], 0.3, "aborted"),
    ],
)
def test_the_outcome_says_what_became_of_the_aircraft(
    outcome: str, last: TelemetrySample, records: list[dict[str, Any]], silent_s: float, expected: str
) -> None:
    verdict = judge(outcome, last, records, silent_s=silent_s, link_loss_s=LINK_LOSS_S)
    assert verdict.outcome == expected
    changed = expected != outcome or outcome in ("failed", "interrupted")
    assert (verdict.note is not None) == changed, verdict
    if expected == LOST or outcome in ("failed", "interrupted"):
        assert verdict.note is not None and "lost" in verdict.note and f"{last.alt_m:.1f} m" in verdict.note


def test_no_telemetry_at_all_leaves_the_outcome_as_it_is() -> None:
    assert judge("failed", None, [], silent_s=None, link_loss_s=LINK_LOSS_S).outcome == "failed"
    assert judge("returned", AIR_AWAY, [], silent_s=None, link_loss_s=LINK_LOSS_S).outcome == "failed"


LEG = """\
plan_id: far-leg
goal: Fly a long leg at 10 m, then come home.
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: out, action: fly_to, depends_on: [up], args: {north_m: 150, east_m: 0, alt_m: 10}}
  - {id: home, action: rtl, depends_on: [out]}
"""
HOME = """\
plan_id: up-and-home
goal: Take off to 10 m and come home.
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: home, action: rtl, depends_on: [up]}
"""


@pytest.fixture
def sim() -> Iterator[tuple[str, subprocess.Popen[str]]]:
    port = free_udp_port()
    proc = start_sim("--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none", "--speed", "1")
    try:
        assert listening_port(proc) == port
        yield f"udp://127.0.0.1:{port}", proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate(timeout=10)


def telemetry_tail(runs: Path) -> dict[str, Any] | None:
    """The last line of the run's ``telemetry.jsonl`` (None before there is one)."""
    files = list(runs.glob("*/telemetry.jsonl"))
    rows = files[0].read_text(encoding="utf-8").splitlines() if files else []
    try:
        return json.loads(rows[-1]) if rows else None
    except ValueError:
        return None  # a line being written


@pytest.mark.timeout(180)
@pytest.mark.parametrize(
    ("mission", "kill_when", "why"),
    [
        (LEG, lambda t: t["north_m"] > 15.0 and t["mode"] == "hold", "on the long leg"),
        (HOME, lambda t: t["mode"] == "rtl" and t["alt_m"] > 4.0, "during the mission's own return"),
    ],
    ids=["mid-leg", "mid-return"],
)
def test_a_vehicle_killed_under_the_run_is_lost_not_returned(
    mission: str, kill_when: Any, why: str, sim: tuple[str, subprocess.Popen[str]], tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    url, proc = sim
    path = tmp_path / "mission.yaml"
    path.write_text(mission, encoding="utf-8")
    runs = tmp_path / "runs"
    codes: list[int] = []
    flying = threading.Thread(target=lambda: codes.append(run_main([str(path), "--connect", url, "--runs-dir",
                              str(runs), "--camera-hz", "2"])), daemon=True)  # fmt: skip
    flying.start()
    wait_for(lambda: (t := telemetry_tail(runs)) is not None and kill_when(t), 120, what=f"the aircraft {why}")
    proc.send_signal(signal.SIGKILL)
    killed = time.monotonic()
    flying.join(120)
    took = time.monotonic() - killed
    assert not flying.is_alive() and codes == [1], codes
    assert took < LINK_LOSS_S + 25.0, took  # bounded: the failsafe's 10 s, a return unanswered, the silence bound
    said = capsys.readouterr()
    assert "Traceback" not in said.err
    (run_dir,) = runs.iterdir()
    trace = [json.loads(line) for line in (run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()]
    (end,) = [r for r in trace if r.get("kind") == "run" and r.get("event") == "end"]
    assert end["outcome"] == LOST and end["ended"].startswith("in the air"), end
    report = (run_dir / "report.md").read_text(encoding="utf-8")
    assert "Outcome: **lost**" in report and "The vehicle was lost" in report
    assert f": lost: {path}" in said.out
