"""The CLIs map the error root to exit statuses: InputError 2, any other error of ours 1, one line, no traceback."""

from __future__ import annotations

import argparse
from collections.abc import Callable

import pytest

from agentic_core import cli as core_cli
from agentic_core.contracts import AgenticUAVError, InputError, RunFailure
from evaluation.campaign import cli as campaign_cli
from evaluation.paper import cli as paper_cli
from evaluation.stats import cli as stats_cli
from flight import cli as flight_cli

ERRORS: list[tuple[AgenticUAVError, int]] = [
    (InputError("mission.yaml:3:7: steps[0].args.alt_m: must be positive"), 2),
    (RunFailure("the vehicle stopped answering"), 1),
    (AgenticUAVError("something of ours went wrong"), 1),
]


def _raiser(error: AgenticUAVError) -> Callable[..., int]:
    def raise_it(*_args: object, **_kwargs: object) -> int:
        raise error

    return raise_it


@pytest.mark.parametrize(("error", "status"), ERRORS)
def test_agentic_uav_maps_errors_to_exit_statuses(
    error: AgenticUAVError, status: int, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(core_cli, "_main", _raiser(error))
    assert core_cli.main(["validate", "x.yaml"]) == status
    err = capsys.readouterr().err
    assert err == f"agentic-uav: error: {error}\n"
    assert "Traceback" not in err


@pytest.mark.parametrize(("error", "status"), ERRORS)
def test_sim_cli_maps_errors(
    error: AgenticUAVError, status: int, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(flight_cli, "_main", _raiser(error))
    assert flight_cli.main(["--bind", "127.0.0.1:0"]) == status
    assert capsys.readouterr().err == f"agentic-uav sim: error: {error}\n"


@pytest.mark.parametrize(("error", "status"), ERRORS)
@pytest.mark.parametrize("module", [stats_cli, paper_cli])
def test_eval_clis_map_errors(
    module: object,
    error: AgenticUAVError,
    status: int,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setattr(module, "run", _raiser(error))
    argv = ["results.csv"] if module is stats_cli else []
    main: Callable[[list[str]], int] = module.main  # type: ignore[attr-defined]
    assert main(argv) == status
    assert capsys.readouterr().err.endswith(f"error: {error}\n")


@pytest.mark.parametrize(("error", "status"), ERRORS)
def test_campaign_cli_maps_errors(
    error: AgenticUAVError, status: int, monkeypatch: pytest.MonkeyPatch, tmp_path: object
) -> None:
    def run(args: argparse.Namespace, out: object, err: object) -> int:
        raise error

    monkeypatch.setattr(campaign_cli, "_run", run)
    import io

    err = io.StringIO()
    assert campaign_cli.main(["--out", str(tmp_path)], stdout=io.StringIO(), stderr=err) == status
    assert err.getvalue().endswith(f"error: {error}\n")


def test_a_multi_problem_error_prints_its_problems_one_a_line(capsys: pytest.CaptureFixture[str]) -> None:
    from agentic_core.contracts import report_error

    assert report_error("prog", InputError("a.yaml:1:1: first\na.yaml:2:1: second"), __import__("sys").stderr) == 2
    assert capsys.readouterr().err == "prog: error: a.yaml:1:1: first\na.yaml:2:1: second\n"


def test_a_real_bad_mission_exits_2_with_its_location(tmp_path: object, capsys: pytest.CaptureFixture[str]) -> None:
    from pathlib import Path

    mission = Path(str(tmp_path)) / "bad.yaml"
    mission.write_text("plan_id: p\ngoal: g\nsteps:\n  - id: a\n    action: no_such_action\n")
    assert core_cli.main(["plan", str(mission)]) == 2
    err = capsys.readouterr().err
    assert "bad.yaml:" in err
    assert "Traceback" not in err
