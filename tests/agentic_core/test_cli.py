"""The agentic-uav command line and the demo it runs."""

import subprocess
import sys
from pathlib import Path

import pytest

from agentic_core import __version__
from agentic_core.cli import demo_argv, main
from agentic_core.demo import run_demo

REPO = Path(__file__).resolve().parents[2]


def test_demo_approves_by_policy_and_leaves_a_checkpointed_run(tmp_path: Path) -> None:
    lines: list[str] = []
    final = run_demo(tmp_path, echo=lines.append)
    assert final["outcome"] == "rescue kit dispatched"
    assert final["casualties"] == ["east"]
    assert any("headless policy answers 'approve'" in line for line in lines)
    (run_dir,) = list(tmp_path.iterdir())
    assert (run_dir / "checkpoints.sqlite").stat().st_size > 0
    assert "graph TD;" in (run_dir / "graph.mmd").read_text()


def test_demo_decline(tmp_path: Path) -> None:
    assert run_demo(tmp_path, approve=False, echo=lambda _: None)["outcome"] == "operator declined dispatch"


def test_cli_demo_is_make_demo_one_flight_of_the_emergency_mission(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    flown: list[list[str]] = []

    def fly(argv: list[str]) -> int:
        flown.append(list(argv))
        return 0

    monkeypatch.setattr("agentic_core.run.cli.main", fly)
    assert main(["demo", "--runs-dir", str(tmp_path), "--decline"]) == 0
    assert flown == [demo_argv(str(tmp_path), True)]
    mission, *rest = flown[0]
    assert Path(mission) == REPO / "missions" / "hajj_emergency.yaml" and rest[-1] == "--decline"
    makefile = (REPO / "Makefile").read_text()
    recipe = makefile[makefile.index("\ndemo:") :].split("\n")[2]
    assert recipe.strip() == "$(PY) -m agentic_core demo"  # make demo runs the very same command
    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert __version__ in capsys.readouterr().out


def test_cli_without_a_command_prints_help_and_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert "usage: agentic-uav" in capsys.readouterr().out


def test_python_dash_m_entry_point() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "agentic_core", "--version"], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    assert __version__ in proc.stdout


def test_eval_stats_and_paper_are_wired(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    results = tmp_path / "results.csv"
    rows = ["system,processing_time_s"] + [f"{s},{t}" for s in ("a", "b", "c") for t in (1.0, 1.5, 2.0, 2.5, 3.1)]
    results.write_text("\n".join(rows) + "\n")
    assert main(["eval", "stats", str(results), "--format", "json"]) == 0
    assert '"processing_time_s"' in capsys.readouterr().out
    assert main(["eval", "stats", str(tmp_path / "missing.csv")]) == 2
    assert "missing.csv" in capsys.readouterr().err
    assert main(["eval", "paper", "--format", "markdown"]) == 0
    assert "reproduced" in capsys.readouterr().out


def test_eval_subcommand_help_comes_from_the_evaluation_package(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "stats", "--help"]) == 0
    assert "usage: agentic-uav eval stats" in capsys.readouterr().out


MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def test_plan_prints_supersteps_and_mermaid(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", str(MISSIONS / "inspect_perimeter.yaml"), "--param", "wind_limit_mps=12"]) == 0
    out = capsys.readouterr().out
    assert "superstep 1: check_weather, climb" in out and "'wind_limit_mps': 12.0" in out
    assert main(["plan", str(MISSIONS / "hajj_emergency.yaml"), "--mermaid"]) == 0
    drawing = capsys.readouterr().out
    assert drawing.startswith("flowchart TD") and "  patrol --> go_home" in drawing and "__reflect__" not in drawing


def test_plan_refuses_a_bad_parameter(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", str(MISSIONS / "hajj_patrol.yaml"), "--param", "rounds=many"]) == 2
    assert "parameter 'rounds' is an integer, not 'many'" in capsys.readouterr().err
    assert main(["plan", str(MISSIONS / "hajj_patrol.yaml"), "--param", "rounds"]) == 2
    assert "--param takes name=value" in capsys.readouterr().err


def test_schema_mission_is_json(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert main(["schema", "mission"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["title"] == "agentic-uavs mission (PolicyGraph)" and "steps" in schema["properties"]


@pytest.mark.parametrize(("smtp_host", "status"), [(None, 0), ("mail.invalid", 3)])
def test_the_demo_without_a_mail_server_is_not_a_failure_but_a_failed_mail_server_is(
    smtp_host: str | None, status: int, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The embedded defaults send no e-mail: the demo's run ends ``degraded`` (exit 3) by design, and the demo says
    so and exits 0; with a mail server configured, a degraded run is a real one and keeps its status."""
    monkeypatch.setattr("agentic_core.run.cli.main", lambda argv: 3)
    if smtp_host is None:
        monkeypatch.delenv("AGENTIC_UAV_SMTP_HOST", raising=False)
    else:
        monkeypatch.setenv("AGENTIC_UAV_SMTP_HOST", smtp_host)
    assert main(["demo"]) == status
    assert ("outbox" in capsys.readouterr().err) == (status == 0)
