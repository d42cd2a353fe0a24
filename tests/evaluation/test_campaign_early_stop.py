"""``--stop-at-width``: a campaign stops adding scenes once its primary comparison's interval is narrow enough,
never before ``--stop-min-scenes``, keeps what it ran, and goes on to every scene when run again without it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from agentic_core.cli import main as agentic_main
from evaluation.campaign import read_records
from evaluation.campaign.early_stop import StopRule
from tests.evaluation.campaign_scenes import write_scenes


@pytest.mark.parametrize("n", [2, 3, 7, 30])
def test_the_interval_is_the_paired_t_interval(n: int) -> None:
    rng = np.random.default_rng(n)
    treatment, baseline = rng.normal(0.8, 0.05, n), rng.normal(0.7, 0.05, n)
    rule = StopRule(width=1.0, treatment="a", baseline="b", metric="detection_confidence", min_scenes=2)
    rows = [(f"s{i}", name, {"detection_confidence": float(v)}) for i in range(n) for name, v in
            (("a", treatment[i]), ("b", baseline[i]))]  # fmt: skip
    check = rule.check(rows)
    reference = stats.ttest_1samp(treatment - baseline, 0.0).confidence_interval(0.95)
    assert check.n == n
    assert check.low == pytest.approx(reference.low, rel=1e-9)
    assert check.high == pytest.approx(reference.high, rel=1e-9)


def test_scenes_missing_a_value_or_a_system_are_left_out_and_bools_count_as_numbers() -> None:
    rule = StopRule(width=1.0, treatment="a", baseline="b", metric="person_detected", min_scenes=2)
    rows: list[tuple[str, str, dict[str, object]]] = [
        ("s1", "a", {"person_detected": True}),
        ("s1", "b", {"person_detected": False}),
        ("s2", "a", {"person_detected": True}),  # no baseline record
        ("s3", "a", {"person_detected": None}),
        ("s3", "b", {"person_detected": True}),
        ("s4", "a", {"person_detected": float("nan")}),
        ("s4", "b", {"person_detected": True}),
        ("s5", "c", {"person_detected": True}),  # another system
        ("s6", "a", {"person_detected": False}),
        ("s6", "b", {"person_detected": False}),
    ]
    check = rule.check(rows)
    assert check.n == 2 and check.mean == pytest.approx(0.5)


def test_a_zero_width_interval_does_not_answer_before_the_minimum_number_of_scenes() -> None:
    rule = StopRule(width=0.01, treatment="a", baseline="b", min_scenes=4)
    rows = [(f"s{i}", s, {"detection_confidence": 0.5}) for i in range(3) for s in ("a", "b")]
    assert rule.check(rows).width == 0.0 and not rule.check(rows).answered
    rows += [("s3", "a", {"detection_confidence": 0.5}), ("s3", "b", {"detection_confidence": 0.5})]
    assert rule.check(rows).answered
    assert not StopRule(width=0.01, treatment="a", baseline="b", min_scenes=2).check(rows[:2]).answered  # n = 1


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--stop-at-width", "0"], "--stop-at-width: Input should be greater than 0"),
        (["--stop-at-width", "-1"], "--stop-at-width: Input should be greater than 0"),
        (["--stop-at-width", "0.1", "--stop-min-scenes", "1"], "--stop-min-scenes: Input should be greater than"),
        (["--stop-at-width", "0.1", "--stop-metric", "scene_id"], "--stop-metric 'scene_id' is not a numeric"),
        (["--stop-at-width", "0.1", "--stop-compare", "rules,llm"], "--stop-compare: 'llm' is not a system"),
        (["--stop-at-width", "0.1", "--stop-compare", "rules"], "--stop-compare 'rules': expected TREATMENT,BASELINE"),
        (["--stop-at-width", "0.1", "--stop-compare", "rules,rules"], "two different systems"),
        (["--stop-compare", "rules,yolo"], "--stop-compare needs --stop-at-width"),
        (["--stop-at-width", "0.1", "--systems", "rules"], "compares two systems; this campaign has one"),
    ],
)
def test_a_bad_stopping_rule_is_a_usage_error_naming_the_option(
    extra: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "c"
    args = ["eval", "campaign", "--scenes", "2", "--frames", "5", "--out", str(out), "--quiet", *extra]
    assert agentic_main(args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()  # refused before anything ran


def test_a_campaign_stops_at_the_minimum_once_answered_and_goes_on_when_run_again_without_the_rule(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    files = write_scenes(tmp_path, first_seed=700, persons=150, prefix="stop", count=5)
    out = tmp_path / "c"
    base = ["eval", "campaign", "--scene-file", *files, "--frames", "20", "--out", str(out), "--quiet", "--no-stats"]
    rule = ["--stop-at-width", "100", "--stop-min-scenes", "3", "--stop-compare", "rules,yolo"]
    assert agentic_main([*base, *rule]) == 0
    said = capsys.readouterr().out
    assert "stopped early, 3 of 5 scenes: detection_confidence rules − yolo" in said
    assert "campaign complete: 6 records (3 scenes × 2 systems; 6 run now)" in said
    records = read_records(out / "results.jsonl")
    assert len({r.scene_id for r in records}) == 3 and len(records) == 6
    csv_rows = (out / "results.csv").read_text(encoding="utf-8").strip().splitlines()
    assert len(csv_rows) == 1 + 6
    assert json.loads((out / "metrics.json").read_text())["systems"][0]["n"] == 3

    assert agentic_main([*base, *rule]) == 0  # the same command again: answered already, nothing new runs
    assert "6 records (3 scenes × 2 systems; 0 run now, 6 from an earlier run)" in capsys.readouterr().out

    assert agentic_main(base) == 0  # without the rule: every scene
    said = capsys.readouterr().out
    assert "stopped early" not in said
    assert "campaign complete: 10 records (5 scenes × 2 systems; 4 run now, 6 from an earlier run)" in said
