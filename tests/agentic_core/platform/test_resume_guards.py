"""Resume, attacked where an outside tester broke it: a run resumed while it still flies, or resumed twice at once;
a damaged ``checkpoints.db``; a run killed before its first checkpoint; an alert sent just before the kill; a
vehicle reached with ``--connect`` that holds the fence armed and will not take another over its unsigned link."""

from __future__ import annotations

import json
import math
import shutil
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from agentic_core.graph.checkpoint.sqlite import SqliteSaver
from agentic_core.run.resume_point import CHECKPOINTS_FILE
from tests.flight.test_cli import free_udp_port
from tests.flight.test_cli_vehicle import listening_port, stop

from .conftest import NEAR, REPO, assert_served, of_kind, telemetry, tools_ok, trace
from .test_resume import command, environment, kill_when, resume, wait_for_trace

CHEAP = ("--camera-hz", "5")


def folder_of(runs: Path) -> Path:
    (folder,) = [p for p in runs.iterdir() if p.is_dir()]
    return folder


def stop_now(proc: subprocess.Popen[Any]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30.0)
    if proc.stdin is not None:
        proc.stdin.close()


def alerted(outcome: Any) -> bool:
    """Whether a task's outcome is the alert step's, done."""
    return ("status", {"alert_medics": "ok"}) in getattr(outcome, "writes", [])


def as_if_killed_before_the_alert_was_heard(folder: Path) -> None:
    """The run's files as a kill leaves them when it comes after the alert was sent and kept in the audit log, but
    before the trace and the graph heard of it (the tester's kill at "land_near: approved"): the alert's trace
    record and what followed it gone, and its step's outcome gone from the checkpoints, so the step runs again on
    resume and its alert is replayed from the audit log."""
    assert "alerts.notify" in (folder / "audit.jsonl").read_text(encoding="utf-8")
    path = folder / "trace.jsonl"
    lines = path.read_text(encoding="utf-8").splitlines()
    cut = next(n for n, line in enumerate(lines) if '"name":"alerts.notify"' in line and '"kind":"tool"' in line)
    path.write_text("".join(line + "\n" for line in lines[:cut]), encoding="utf-8")
    with sqlite3.connect(folder / CHECKPOINTS_FILE) as db:
        rows = db.execute("SELECT rowid, checkpoint_id, body FROM agentic_writes").fetchall()
        (alert,) = [(rowid, ckpt) for rowid, ckpt, body in rows if alerted(SqliteSaver(":memory:").serde.loads(body))]
        (seq,) = db.execute("SELECT seq FROM agentic_checkpoints WHERE checkpoint_id = ?", (alert[1],)).fetchone()
        later = [r[0] for r in db.execute("SELECT checkpoint_id FROM agentic_checkpoints WHERE seq > ?", (seq,))]
        db.execute("DELETE FROM agentic_writes WHERE rowid = ?", (alert[0],))
        db.executemany("DELETE FROM agentic_writes WHERE checkpoint_id = ?", [(c,) for c in later])
        db.execute("DELETE FROM agentic_checkpoints WHERE seq > ?", (seq,))
    db.close()


def resume_approving(runs: Path, run_id: str, smtp: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "agentic_core", "run", "--resume", run_id, "--runs-dir", str(runs), "--approval",
         "approve"],
        cwd=REPO, env=environment(smtp), stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=300.0,
    )  # fmt: skip


def alerted_and_asking(records: list[dict[str, Any]]) -> bool:
    """The alert sent, and the landing beside the casualty waiting for the operator's yes (a steady state)."""
    return bool(tools_ok(records, "alerts.notify")) and any(
        r.get("status") == "asked" for r in of_kind(records, "approval")
    )


@pytest.mark.slow
def test_one_process_per_run_a_damaged_checkpoint_refused_and_an_alert_before_the_kill_answers(
    tmp_path: Path, smtp: Any
) -> None:
    runs = tmp_path / "runs"
    output = tmp_path / "first.out"
    asking = ("--approval", "ask", "--approval-timeout-s", "900")
    with output.open("w", encoding="utf-8") as sink:
        first = subprocess.Popen(command(runs, *CHEAP, *asking), cwd=REPO, env=environment(smtp),
                                 stdin=subprocess.PIPE, stdout=sink, stderr=subprocess.STDOUT)  # fmt: skip
    try:
        wait_for_trace(runs, alerted_and_asking, "the alert, and the question", first, output)
        folder = folder_of(runs)
        alive = resume_approving(runs, folder.name, smtp)  # the run is still on: no second process on its aircraft
        assert alive.returncode == 2, alive.stderr[-2000:]
        assert f"run {folder.name} is already being flown by pid {first.pid}" in alive.stderr
        assert "Traceback" not in alive.stderr
    finally:
        stop_now(first)
    as_if_killed_before_the_alert_was_heard(folder)
    before = trace(folder)

    # a damaged checkpoint database is named, exit 2, before anything is sent to the aircraft
    for n, damage in enumerate(("random bytes", "cut to 8 KiB")):
        copy = tmp_path / f"copy{n}" / folder.name
        shutil.copytree(folder, copy)
        db = copy / CHECKPOINTS_FILE
        if damage == "random bytes":
            db.write_bytes(bytes((i * 7919 + n) % 251 for i in range(64 * 1024)))
        else:
            with db.open("r+b") as f:
                f.truncate(8192)
        done = resume_approving(copy.parent, folder.name, smtp)
        assert done.returncode == 2, (damage, done.stderr[-2000:])
        assert str(db) in done.stderr and "Traceback" not in done.stderr, done.stderr[-2000:]
        assert trace(copy) == before, f"{damage}: the refused resume wrote to the run's trace"

    # two resumes at once: the second refused at once; the first killed, its lock goes with it
    output = tmp_path / "second.out"
    with output.open("w", encoding="utf-8") as sink:
        second = subprocess.Popen(
            [sys.executable, "-m", "agentic_core", "run", "--resume", folder.name, "--runs-dir", str(runs), "--speed",
             "1", "--approval", "approve"],  # at real time: still flying when the third process tries
            cwd=REPO, env=environment(smtp), stdin=subprocess.DEVNULL, stdout=sink, stderr=subprocess.STDOUT,
        )  # fmt: skip
    try:
        resumed = [r.get("event") for r in of_kind(before, "run")].count("resume")

        def resuming(records: list[dict[str, Any]]) -> bool:
            return [r.get("event") for r in of_kind(records, "run")].count("resume") > resumed

        wait_for_trace(runs, resuming, "the second process resuming", second, output)
        third = resume_approving(runs, folder.name, smtp)
        assert third.returncode == 2, third.stderr[-2000:]
        assert f"run {folder.name} is already being resumed by pid {second.pid}" in third.stderr
    finally:
        stop_now(second)
    done = resume_approving(runs, folder.name, smtp)
    assert done.returncode == 0, done.stderr[-3000:]
    assert f"{folder.name}: completed" in done.stdout
    records = trace(folder)
    assert len(smtp.inbox.envelopes) == 1  # one e-mail across all the processes, sent before the kill
    (replayed,) = {r["key"] for r in of_kind(records, "tool") if r.get("name") == "alerts.notify"}
    assert all(r.get("replayed") for r in of_kind(records, "tool") if r.get("key") == replayed)
    assert len(tools_ok(records, "flight.deploy_payload")) == 1
    assert of_kind(records, "run")[-1]["outcome"] == "completed"
    report = (folder / "report.md").read_text(encoding="utf-8")
    assert "no alert was sent" not in report
    (casualty,) = [line for line in report.splitlines() if line.startswith("- Casualty ")]
    tracked = [r["object"] for r in of_kind(records, "log") if r.get("truth") == "P-12"]
    assert tracked and f"{tracked[0]} (scene P-12)" in casualty and "never tracked" not in casualty, casualty
    first_seen = float(casualty.split("first detected at ")[1].split(" s")[0])
    resumed_at = [r["sim_t"] for r in of_kind(records, "run") if r.get("event") == "resume"]
    assert first_seen < resumed_at[0]  # seen by the first process, not first seen by the last one


def before_the_first_checkpoint(records: list[dict[str, Any]]) -> bool:
    return any(r.get("event") == "start" for r in of_kind(records, "run"))


@pytest.mark.slow
def test_a_run_killed_before_its_first_checkpoint_starts_again(tmp_path: Path, smtp: Any) -> None:
    runs = tmp_path / "runs"
    folder = kill_when(runs, smtp, before_the_first_checkpoint, *CHEAP)
    before = trace(folder)
    assert not of_kind(before, "step"), "killed too late for this test: a step had begun"
    done = resume(runs, folder.name, smtp)
    assert done.returncode == 0, done.stderr[-3000:]
    assert f"{folder.name}: completed" in done.stdout and "Traceback" not in done.stderr
    records = assert_served(folder, smtp)
    assert len(tools_ok(records, "flight.takeoff")) >= 1 and records[0]["event"] == "start"


WAYPOINTS = REPO / "missions" / "examples" / "waypoints_home.yaml"


def sim(port: int) -> subprocess.Popen[str]:
    """``agentic-uav sim`` in a process of its own, its link unsigned (no ``--signing-key``). At four times real
    time PX4's 10 s data-link timeout is 2.5 s of the wall clock, less than a resumed run may take to start on a
    loaded machine (it once came home on its own before the resumed run was heard): 60 s (15 s of wall clock) leave
    room for the restart this test is about."""
    return subprocess.Popen(
        [sys.executable, "-m", "flight.cli", "--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none",
         "--scene", str(NEAR), "--speed", "4", "--param", "COM_DL_LOSS_T=60"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO,
    )  # fmt: skip


def fly_to_ok(count: int) -> Any:
    def met(records: list[dict[str, Any]]) -> bool:
        return len(tools_ok(records, "flight.fly_to")) >= count

    return met


@pytest.mark.slow
def test_a_connected_run_killed_in_the_air_resumes_and_one_that_cannot_go_on_comes_home(tmp_path: Path) -> None:
    """Killed after its first waypoint, the run resumes on the armed vehicle over its unsigned link (the fence the
    vehicle holds is the run's, so nothing is sent again) and flies on; killed again, and its mission's fence
    changed meanwhile, the vehicle refuses the new one, and the run carries out ``on_abort`` (rtl): home, landed."""
    mission = tmp_path / "missions" / WAYPOINTS.name
    mission.parent.mkdir()
    shutil.copy(WAYPOINTS, mission)
    runs = tmp_path / "runs"
    port = free_udp_port()
    vehicle = sim(port)
    try:
        assert listening_port(vehicle) == port
        run = [sys.executable, "-m", "agentic_core", "run", str(mission), "--connect", f"udp://127.0.0.1:{port}",
               "--runs-dir", str(runs), *CHEAP]  # fmt: skip
        output = tmp_path / "run.out"
        for stage, args in enumerate((run, [*run[:4], "--resume", "ID", "--runs-dir", str(runs)])):
            if stage:
                args[args.index("ID")] = folder_of(runs).name
            with output.open("w", encoding="utf-8") as sink:
                proc = subprocess.Popen(args, cwd=REPO, stdin=subprocess.DEVNULL, stdout=sink,
                                        stderr=subprocess.STDOUT)  # fmt: skip
            try:
                wait_for_trace(runs, fly_to_ok(stage + 1), f"fly_to number {stage + 1}", proc, output)
            finally:
                stop_now(proc)
        folder = folder_of(runs)
        records = trace(folder)
        resumed = next(r["seq"] for r in of_kind(records, "run") if r.get("event") == "resume")
        fences = [r for r in of_kind(records, "tool") if r.get("name") == "flight.set_fence" and r["seq"] > resumed]
        assert [r["status"] for r in fences] == ["ok"]  # taken again on the armed vehicle, unsigned
        mission.write_text(mission.read_text().replace("radius_m: 100", "radius_m: 90"), encoding="utf-8")
        done = subprocess.run([*run[:4], "--resume", folder.name, "--runs-dir", str(runs)], cwd=REPO,
                              capture_output=True, text=True, timeout=300.0)  # fmt: skip
    finally:
        stop(vehicle)
    assert done.returncode == 1 and "did not take the mission's limits" in done.stderr, done.stderr[-3000:]
    assert "Traceback" not in done.stderr
    records = trace(folder)
    last = max(r["seq"] for r in of_kind(records, "run") if r.get("event") == "resume")
    after = [r for r in records if r["seq"] > last]
    assert [r["status"] for r in after if r.get("name") == "flight.set_fence"] == ["error"]
    assert [r["status"] for r in after if r.get("name") == "flight.rtl"] == ["ok"]
    end = telemetry(folder)[-1]
    assert end["alt_m"] < 0.5 and math.hypot(end["north_m"], end["east_m"]) < 3.0, json.dumps(end)
    assert "on the ground" in of_kind(records, "run")[-1]["ended"]
