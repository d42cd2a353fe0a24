"""Control refined from traces: the costs come from telemetry as a run records it, the tuner stays inside its
bounds, and the acceptance rule takes a candidate only when held-out gust flights are significantly better — a
candidate no better than the incumbent, or worse, is rejected."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agentic_core.cli import main as cli_main
from agentic_core.contracts.extras import MissingExtra, require
from evaluation.tuning.cli import TuneSettings, run_tuning
from evaluation.tuning.flights import TARGET, costs, fly, read_telemetry, write_telemetry
from evaluation.tuning.tuner import BOUNDS, gains_at, judge
from flight.sim.controller import Gains

SLUGGISH = Gains(pos_xy=0.3, vel_xy_p=1.0)  # inside the bounds, but it drifts in the gusts
HELD_OUT = range(500, 506)  # six flights: the fewest for which a signed-rank p can fall below 0.05


def test_a_better_candidate_is_accepted_and_a_no_better_or_worse_one_rejected(tmp_path: Path) -> None:
    better = judge(SLUGGISH, Gains(), HELD_OUT, record=tmp_path)
    assert better.accepted and better.test.mean_difference < 0 and better.test.significant(0.05)
    same = judge(Gains(), Gains(), HELD_OUT)
    assert not same.accepted and same.test.p.value == 1.0
    worse = judge(Gains(), SLUGGISH, HELD_OUT)
    assert not worse.accepted and worse.test.mean_difference > 0
    assert "rejected" in worse.line() and "p = " in worse.line()
    assert len(list(tmp_path.glob("*.jsonl"))) == 2 * len(HELD_OUT)  # judged from recorded telemetry


def test_costs_read_from_recorded_telemetry_equal_the_flights_own(tmp_path: Path) -> None:
    rows = fly(Gains(), seed=3, hold_s=4.0)
    write_telemetry(rows, tmp_path / "telemetry.jsonl")
    again = read_telemetry(tmp_path / "telemetry.jsonl")
    assert costs(again, TARGET, rows[0].time_s) == costs(rows, TARGET, rows[0].time_s)
    with pytest.raises(ValueError, match="too few telemetry samples"):
        costs(rows[:3], TARGET, rows[0].time_s)


def test_candidates_stay_inside_the_safe_bounds() -> None:
    wild = gains_at([-5.0, 9.0, 0.5, 2.0], Gains())
    for name, (lo, hi) in BOUNDS.items():
        assert lo <= getattr(wild, name) <= hi
    assert wild.pos_z == Gains().pos_z  # untouched gains stay as they were


def test_a_tiny_tuning_reports_its_verdict_and_p_value(tmp_path: Path) -> None:
    report = run_tuning(TuneSettings(generations=1, popsize=2, train=1, held_out=2), tmp_path)
    written = json.loads((tmp_path / "tune.json").read_text(encoding="utf-8"))
    assert written["accepted"] is False  # two flights can never be significant: the incumbent stays
    assert written["gains"] == written["incumbent"] and "p_text" in written["test"] and report["verdict"]
    for name, value in written["candidate"].items():
        assert BOUNDS[name][0] <= value <= BOUNDS[name][1]


def test_bad_settings_and_a_missing_extra_say_what_to_do(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["eval", "tune", "--popsize", "1"]) == 2
    assert "--popsize" in capsys.readouterr().err
    with pytest.raises(MissingExtra, match=r"agentic-uavs\[tune\]"):
        require("no_such_cma_module", "tune")
