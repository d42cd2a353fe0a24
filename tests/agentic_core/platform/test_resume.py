"""``kill -9`` a run at three points — on patrol, right after the alert, while it waits for the operator — and
``agentic-uav run --resume RUN_ID`` finishes the mission with exactly one alert e-mail and one kit release: the
graph goes on from its checkpoint, the simulated aircraft from its snapshot, and a side effect done before the kill
is replayed from the audit log instead of done again."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from agentic_core.contracts.geodesy import local_offset
from agentic_core.run.stops import GONE_M
from flight.sim.scene_file import load_scene
from tests.tlogs import read_tlog
from tests.waiting import wait_for

from .conftest import EMERGENCY, NEAR, PARAMS, REPO, assert_served, of_kind, tools_ok, trace

Condition = Callable[[list[dict[str, Any]]], bool]


def command(runs: Path, *extra: str) -> list[str]:
    params = [arg for name, value in PARAMS.items() for arg in ("--param", f"{name}={value}")]
    return [sys.executable, "-m", "agentic_core", "run", str(EMERGENCY), "--scene", str(NEAR), "--runs-dir",
            str(runs), "--camera-hz", "15", *params, *extra]  # fmt: skip


def environment(smtp: Any) -> dict[str, str]:
    return {
        **os.environ, "AGENTIC_UAV_SMTP_HOST": smtp.host, "AGENTIC_UAV_SMTP_PORT": str(smtp.port),
        "AGENTIC_UAV_SMTP_STARTTLS": "false", "PYTHONUNBUFFERED": "1",
    }  # fmt: skip


def kill_when(runs: Path, smtp: Any, condition: Condition, *extra: str) -> Path:
    """Start a run in a process of its own, SIGKILL it once its trace meets ``condition``; its folder."""
    output = runs.parent / "killed-run.out"
    with output.open("w", encoding="utf-8") as sink:
        proc = subprocess.Popen(
            command(runs, *extra), cwd=REPO, env=environment(smtp), stdin=subprocess.PIPE, stdout=sink,
            stderr=subprocess.STDOUT,
        )  # fmt: skip
    try:
        wait_for_trace(runs, condition, "the moment to kill the run", proc, output)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10.0)
        if proc.stdin is not None:  # held open so an operator's question waits rather than reading an end
            proc.stdin.close()
    (folder,) = [p for p in runs.iterdir() if p.is_dir()]
    return folder


def wait_for_trace(
    runs: Path, condition: Condition, what: str, proc: subprocess.Popen[Any], output: Path | None = None
) -> None:
    """Wait until the one run folder under ``runs`` has a trace that meets ``condition``; a run that ends first,
    or takes too long, fails the test with what it printed and the end of its trace."""

    def records() -> list[dict[str, Any]]:
        folders = [p for p in runs.iterdir() if p.is_dir()] if runs.exists() else []
        return trace(folders[0]) if folders and (folders[0] / "trace.jsonl").is_file() else []

    def met() -> bool:
        if condition(records()):
            return True
        if proc.poll() is not None:
            raise AssertionError(f"the run ended (exit {proc.returncode}) before {what}\n{told()}")
        return False

    def told() -> str:
        tail = [f"{r.get('sim_t')} {r.get('kind')}: {r.get('summary', '')}" for r in records()[-25:]]
        printed = output.read_text(encoding="utf-8", errors="replace")[-3000:] if output else ""
        return "trace ends:\n" + "\n".join(tail) + "\nprinted:\n" + printed

    try:
        wait_for(met, timeout_s=120.0, interval_s=0.05, what=what)  # each poll reads the whole trace
    except AssertionError as timed_out:
        if "timed out" not in str(timed_out):
            raise
        raise AssertionError(f"{timed_out}\n{told()}") from None


def resume(runs: Path, run_id: str, smtp: Any, answers: str = "") -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "agentic_core", "run", "--resume", run_id, "--runs-dir", str(runs)],
        cwd=REPO, env=environment(smtp), input=answers, capture_output=True, text=True, timeout=300.0,
    )  # fmt: skip


def on_patrol(records: list[dict[str, Any]]) -> bool:
    return bool(tools_ok(records, "flight.takeoff"))


def after_the_alert(records: list[dict[str, Any]]) -> bool:
    return bool(tools_ok(records, "alerts.notify"))


def waiting_for_the_operator(records: list[dict[str, Any]]) -> bool:
    return any(r.get("status") == "asked" for r in of_kind(records, "approval"))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("condition", "extra", "answers"),
    [
        (on_patrol, (), ""),
        (after_the_alert, (), ""),
        (waiting_for_the_operator, ("--approval", "ask", "--approval-timeout-s", "60"), "y\ny\n"),
    ],
    ids=["on-patrol", "after-the-alert", "waiting-on-approval"],
)
def test_a_killed_run_resumes_and_does_nothing_twice(
    tmp_path: Path, smtp: Any, condition: Condition, extra: tuple[str, ...], answers: str
) -> None:
    runs = tmp_path / "runs"
    folder = kill_when(runs, smtp, condition, *extra)
    before = trace(folder)
    assert not any(r["kind"] == "run" and r.get("event") == "end" for r in before), "the run ended before the kill"
    done = resume(runs, folder.name, smtp, answers)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    assert f"{folder.name}: completed" in done.stdout
    records = assert_served(folder, smtp)  # one alert e-mail, one kit release, on the ground beside the casualty
    starts = [r.get("event") for r in of_kind(records, "run")]
    assert starts[0] == "start" and "resume" in starts and starts[-1] == "end"
    seqs = [r["seq"] for r in records]
    assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)  # one event stream across both processes
    resumed_at = next(r for r in of_kind(records, "run") if r.get("event") == "resume")
    assert resumed_at["sim_t"] > 0  # the aircraft and its clock came back from the snapshot, not from the ground
    # one flight log across both processes (a record cut by the kill mended), its stamps never going back
    logged = read_tlog(folder / "flight.tlog")
    stamps = [m._timestamp for m in logged]
    assert stamps == sorted(stamps)
    boot_s = [m.time_boot_ms / 1000 for m in logged if m.get_type() == "GLOBAL_POSITION_INT"]
    assert min(boot_s) < resumed_at["sim_t"] < max(boot_s)


def test_resuming_what_does_not_exist_is_a_clear_error(tmp_path: Path, smtp: Any) -> None:
    done = resume(tmp_path, "no-such-run", smtp)
    assert done.returncode == 2 and "no-such-run" in done.stderr and "Traceback" not in done.stderr


def responding(records: list[dict[str, Any]]) -> bool:
    """The trigger fired for the casualty: the aircraft is on its way to them."""
    return any(r.get("status") == "fired" for r in of_kind(records, "mission"))


def landed_beside(records: list[dict[str, Any]]) -> bool:
    """The aircraft landed beside the casualty (the kit not released yet, or just)."""
    return any(r["args"].get("target_id") for r in tools_ok(records, "flight.land"))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("signum", "moment"),
    [(signal.SIGINT, on_patrol), (signal.SIGTERM, responding), (signal.SIGTERM, landed_beside)],
    ids=["SIGINT-on-patrol", "SIGTERM-while-responding", "SIGTERM-landed-beside-the-casualty"],
)
def test_a_signal_stops_the_run_cleanly_and_it_resumes(
    tmp_path: Path, smtp: Any, signum: int, moment: Condition
) -> None:
    """Ctrl-C or SIGTERM mid-flight, on patrol or while answering the casualty: no traceback, the aircraft does what
    the mission's ``on_abort`` says (RTL), the report says ``interrupted``, exit 1; the run then resumes, goes back to
    where it stopped and finishes the mission, the casualty served."""
    runs = tmp_path / "runs"
    proc = subprocess.Popen(
        command(runs), cwd=REPO, env=environment(smtp), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        wait_for_trace(runs, moment, f"the moment to stop the run ({moment.__name__})", proc)
        proc.send_signal(signum)
        out, err = proc.communicate(timeout=120.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10.0)
    assert proc.returncode == 1, err[-2000:]
    assert "Traceback" not in err and "stopping the run" in err
    (folder,) = [p for p in runs.iterdir() if p.is_dir()]
    assert f"{folder.name}: interrupted" in out
    assert "interrupted" in (folder / "report.md").read_text(encoding="utf-8")
    records = trace(folder)
    (stop,) = of_kind(records, "control")
    assert stop["command"] == "abort" and stop["by"] == "signal"
    # the aircraft did what the mission's on_abort says (rtl, the default) and the trace says where it was taken
    # from; landed beside the casualty, disarmed, there was nothing to do and it stayed there; on the ground and
    # armed (just landed, or spinning up to lift off again) it landed in place rather than take off
    stopped = [r for r in records if r["seq"] > stop["seq"]]
    idle = [r for r in stopped if "nothing to do" in r.get("summary", "")]
    settled = [r for r in stopped if "landing in place" in r.get("summary", "")]
    assert not settled or tools_ok(stopped, "flight.land")
    assert tools_ok(stopped, "flight.rtl") or idle or settled, "the stop did not do what on_abort says"
    left = [r["stopped_at"] for r in stopped if r.get("stopped_at")]
    assert len(left) == (0 if idle or settled else 1)
    assert not [r for r in stopped if r["kind"] == "tool" and "denied" in str(r.get("error"))]  # nothing refused
    done = resume(runs, folder.name, smtp)
    assert done.returncode == 0, done.stderr[-3000:]
    # resumed, it took off again and flew back to where the stop found it, then went on: the casualty, found before
    # the stop (or after it, on patrol), is served, their stillness observed before the stop not judged afresh
    records = assert_served(folder, smtp)
    after = [r for r in records if r["seq"] > stop["seq"]]
    if left:
        assert tools_ok(after, "flight.takeoff"), "the resumed run did not take off again"
        home = load_scene(NEAR).home
        if math.hypot(*local_offset(home.lat_deg, home.lon_deg, left[0]["lat"], left[0]["lon"])) > GONE_M:
            back = [r for r in tools_ok(after, "flight.fly_to") if r["args"].get("lat") == left[0]["lat"]]
            assert back, "the resumed run did not go back to where it stopped"
