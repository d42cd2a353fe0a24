"""The before/after feedback study, tiny: it reports its effects and their p-values (whatever they are), and the
paired test behind it says what it should on known data."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agentic_core.cli import main as cli_main
from evaluation.campaign.feedback_study import StudySettings, run_study
from evaluation.stats.paired import paired_test
from evaluation.stats.pvalues import format_p


@pytest.mark.slow
def test_a_tiny_study_reports_each_effect_with_its_p_value(tmp_path: Path) -> None:
    report = run_study(StudySettings(train=2, held_out=2, persons=8, frames=345), tmp_path)
    assert report["answers"] and all(a["verdict"] in ("approved", "declined") for a in report["answers"])
    assert any(line.startswith("logit P(approve)") for line in report["model"])
    written = json.loads((tmp_path / "feedback_study.json").read_text(encoding="utf-8"))
    assert written["tests"] == report["tests"]
    correct = report["tests"]["correct_severity"]
    assert correct is not None and correct["n"] == 2
    for key in ("mean_difference", "rank_biserial", "p", "p_text"):
        assert key in correct
    assert correct["p_text"] == format_p(paired_test("a", [0.0], "b", [0.0]).p) or 0.0 < correct["p"]["value"] <= 1
    md = (tmp_path / "feedback_study.md").read_text(encoding="utf-8")
    assert "correct_severity: after vs before (Wilcoxon signed-rank" in md and ", p = " in md
    lines = (tmp_path / "records.jsonl").read_text(encoding="utf-8").splitlines()
    assert sorted({json.loads(x)["system"] for x in lines}) == ["after", "before"] and len(lines) == 4


def test_the_paired_test_finds_a_clear_shift_and_none_where_there_is_none() -> None:
    before = [10.0 + 0.1 * i for i in range(12)]
    shifted = paired_test("before", before, "after", [x - 2.0 + 0.01 * i for i, x in enumerate(before)])
    assert shifted.significant(0.05) and shifted.mean_difference < 0 and shifted.rank_biserial == -1.0
    same = paired_test("before", before, "after", before)
    assert same.p.value == 1.0 and not same.significant(0.05) and same.note == "every pair is equal"
    nan_dropped = paired_test("a", [1.0, float("nan"), 3.0], "b", [2.0, 5.0, 4.0])
    assert nan_dropped.n == 2
    with pytest.raises(ValueError, match="no complete pair"):
        paired_test("a", [float("nan")], "b", [1.0])


def test_bad_study_settings_are_refused_naming_the_option(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["eval", "feedback", "--held-out", "1"]) == 2
    err = capsys.readouterr().err
    assert "--held-out" in err and "Traceback" not in err
