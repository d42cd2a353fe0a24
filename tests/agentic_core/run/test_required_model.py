"""A model that is required is required: ``--reasoner llm`` with a model that does not answer stops before
take-off (exit 2, the URL and the fix named, nothing flown); ``hybrid`` says once that it flies on rules alone,
does so (no request reaches any model), and the report says it."""

from __future__ import annotations

import json
import socket
from pathlib import Path
from typing import Any

import pytest

from agentic_core.cli import main
from agentic_core.run.runner import RunSettings, run_mission

REPO = Path(__file__).resolve().parents[3]
EMERGENCY = REPO / "missions" / "hajj_emergency.yaml"
SCENE = Path(__file__).parent / "scenes" / "near_emergency.yaml"


def closed_port() -> int:
    """A local port nothing listens on (bound, then released)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def test_llm_with_an_unreachable_model_stops_before_take_off(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url = f"http://127.0.0.1:{closed_port()}/v1"
    runs = tmp_path / "runs"
    argv = ["run", str(EMERGENCY), "--reasoner", "llm", "--llm", f"openai-compatible:m@{url}", "--runs-dir", str(runs)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    (line,) = [x for x in err.splitlines() if "error" in x]
    assert url in line and "--llm" in line and "--reasoner rules" in line and "nothing was flown" in line
    assert "Traceback" not in err and "flight." not in err  # no tool was called, no vehicle was commanded
    assert not runs.exists() or not any(runs.iterdir())  # no run folder: nothing flew, nothing to resume


@pytest.mark.slow
def test_hybrid_with_an_unreachable_model_flies_on_rules_alone_and_says_so(tmp_path: Path, smtp: Any) -> None:
    url = f"http://127.0.0.1:{closed_port()}/v1"
    settings = RunSettings(
        mission=EMERGENCY, scene=SCENE, runs_dir=tmp_path, reasoner="hybrid", llm=f"openai-compatible:m@{url}",
        params={"rounds": "1", "still_s": "4"}, camera_hz=5.0,  # enough to confirm the casualty on rules
    )  # fmt: skip
    result = run_mission(settings, progress=None)
    assert result.summary.outcome in ("completed", "returned"), result.summary  # the alert was sent: not degraded
    records: list[dict[str, Any]] = [
        json.loads(line) for line in (result.run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()
    ]
    said = [r for r in records if "rules alone" in str(r.get("summary", ""))]
    assert len(said) == 1 and said[0]["level"] == "warning" and url in said[0]["summary"]
    decisions = [r for r in records if r["kind"] == "decision"]
    assert decisions and all(d["reasoner"] == "rules" and not d.get("llm_calls") for d in decisions)
    assert any(d["assessment"] and d["assessment"]["severity"] == "critical" for d in decisions)
    assert not [r for r in records if r["kind"] in ("plan", "reflection")]  # no model planned or reflected
    report = result.report.read_text(encoding="utf-8")
    assert "flew on its rules alone" in report and url in report
    assert result.summary.llm_calls == 0
