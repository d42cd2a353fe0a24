"""A run says whether every critical event got its response: a casualty judged critical with no alert fails the
run (exit 1), an alert that reached only the outbox makes it ``degraded`` (exit 3), and report.md says why."""

from __future__ import annotations

import socket
from pathlib import Path
from typing import Any

import pytest

from agentic_core.run.cli import main as run_main
from agentic_core.run.responses import DEGRADED_EXIT
from agentic_core.run.runner import MissionRun, RunSettings
from tests.conftest import MEDICAL_TEAM

from .conftest import EMERGENCY, NEAR, PARAMS, distance_to_casualty, of_kind, slow_server, telemetry, tools_ok, trace


def settings(tmp_path: Path, url: str) -> RunSettings:
    return RunSettings(
        mission=EMERGENCY, scene=NEAR, runs_dir=tmp_path / "runs", params=PARAMS, reasoner="llm",
        llm=f"openai-compatible:m@{url}/v1", camera_hz=5.0,
    )  # fmt: skip


@pytest.mark.slow
def test_a_model_slower_than_the_deadline_holds_over_the_casualty_and_never_completes_unanswered(
    tmp_path: Path, smtp: Any
) -> None:
    """3 s a call: slower than the 2 s the gate would wait on a track before judging it (and, scaled down, than
    a local model against the hybrid's deadline). The drone holds over the person while the model thinks; the
    run either answers the event (the medical team mailed) and completes, or says it failed."""
    server, _ = slow_server(3.0)
    with server:
        result = MissionRun(settings(tmp_path, server.url)).execute()
    records = trace(result.run_dir)
    first = next(d for d in of_kind(records, "decision") if d["why"].startswith("trigger"))
    assert first["processing_time_s"] >= 3.0 and first["assessment"]["severity"] in ("high", "critical")
    thinking = [t for t in telemetry(result.run_dir) if first["sim_t"] - 3.0 <= t["time_s"] <= first["sim_t"]]
    assert thinking and max(distance_to_casualty(t) for t in thinking) < 27.0  # in the camera's view throughout
    alerted = tools_ok(records, "alerts.notify")
    if result.summary.outcome == "completed":
        assert alerted and len(smtp.inbox.envelopes) == 1
    else:
        assert result.summary.outcome == "failed" and not alerted, result.summary
        assert "no alert was sent" in result.report.read_text(encoding="utf-8")


@pytest.mark.slow
def test_a_confirmed_casualty_with_no_alert_fails_the_run(tmp_path: Path, smtp: Any) -> None:
    """The model judges the casualty critical, then writes a response plan that only hovers: every step of it
    succeeds, the patrol goes home, and today's flight would say "completed". It is ``failed``, and the report
    says which event went without its response. Coming back over the casualty (a new track id) is not a new
    event: the useless plan is not started again and again until the run times out."""
    server, model = slow_server(0.0)
    model.model.plan = [{"id": "look_longer", "action": "hover", "args": {"duration_s": 2}}]
    model.model.still_s = 2.0  # critical at the first look, when the trigger's rule fires
    with server:
        result = MissionRun(settings(tmp_path, server.url)).execute()
    records = trace(result.run_dir)
    assert [r for r in of_kind(records, "trigger") if r["act"]] and not tools_ok(records, "alerts.notify")
    assert any(r["status"] == "planned" for r in of_kind(records, "mission"))  # the plan itself was accepted
    assert result.summary.outcome == "failed"
    assert of_kind(records, "run")[-1]["outcome"] == "failed"
    report = result.report.read_text(encoding="utf-8")
    assert "**failed**" in report and "was judged critical at" in report and "no alert was sent" in report
    assert not smtp.inbox.envelopes
    assert len([r for r in of_kind(records, "mission") if r["status"] == "planned"]) == 1  # once, not in a loop


def _closed_port() -> int:
    """A port on 127.0.0.1 nothing listens on (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow
def test_an_alert_that_reached_only_the_outbox_is_degraded_with_exit_3(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("AGENTIC_UAV_ALERT_RECIPIENTS", MEDICAL_TEAM)
    monkeypatch.setenv("AGENTIC_UAV_SMTP_HOST", "127.0.0.1")
    monkeypatch.setenv("AGENTIC_UAV_SMTP_PORT", str(_closed_port()))
    monkeypatch.setenv("AGENTIC_UAV_SMTP_STARTTLS", "false")
    monkeypatch.setenv("AGENTIC_UAV_HTTP_TIMEOUT_S", "2")
    argv = [str(EMERGENCY), "--scene", str(NEAR), "--runs-dir", str(tmp_path / "runs"), "--camera-hz", "5", "--quiet"]
    argv += [arg for name, value in PARAMS.items() for arg in ("--param", f"{name}={value}")]
    assert run_main(argv) == DEGRADED_EXIT == 3
    out = capsys.readouterr().out
    assert ": degraded:" in out
    (run_dir,) = (tmp_path / "runs").iterdir()
    records = trace(run_dir)
    (alert,) = [r for r in of_kind(records, "tool") if r.get("name") == "alerts.notify"]
    assert alert["status"] == "error" and "copy was kept" in alert["error"]
    assert list((run_dir / "alerts").glob("*.eml"))  # the message waits in the outbox
    report = (run_dir / "report.md").read_text(encoding="utf-8")
    assert "**degraded**" in report and "reached only the outbox" in report
