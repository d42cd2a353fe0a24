"""Three things a new user found in ``eval stats`` on a campaign's own output: the category ``none`` read as a
missing value, the outcomes that matter most left out, and a Mann–Whitney table that printed U twice."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from evaluation.stats import analyze
from evaluation.stats.nonparametric import mann_whitney
from evaluation.stats.render_markdown import render_markdown


def _severity_csv(path: Path) -> Path:
    rows = ["system,severity"]
    rows += [f"yolo,{s}" for s in ["none"] * 6 + ["high"] * 2]
    rows += [f"rules,{s}" for s in ["critical"] * 3 + ["none"] * 5]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_the_category_none_is_a_level_not_a_missing_value(tmp_path: Path) -> None:
    report = analyze(str(_severity_csv(tmp_path / "plain.csv")), group="system")
    (severity,) = report.categorical
    assert set(severity.levels) == {"none", "high", "critical"}
    rows = (dict(zip(severity.levels, row, strict=True)) for row in severity.table)
    counts = dict(zip(severity.groups, rows, strict=True))
    assert counts["yolo"]["none"] == 6 and counts["rules"]["none"] == 5
    rules_critical = next(r for r in severity.rates if r.group == "rules" and r.level == "critical")
    assert rules_critical.count == 3 and rules_critical.n == 8  # not "critical 100%"
    assert severity.chi_square.statistic is not None


def test_an_empty_cell_is_still_missing(tmp_path: Path) -> None:
    path = tmp_path / "gaps.csv"
    path.write_text("system,severity\na,none\na,\na,high\nb,none\nb,high\nb,NA\n", encoding="utf-8")
    (severity,) = analyze(str(path), group="system").categorical
    assert sum(map(sum, severity.table)) == 4


def _records_csv(path: Path) -> Path:
    """Decision records: each system on the same 12 scenes, half with a casualty (the minimum columns)."""
    rows = ["system,processing_time_s,person_detected,n_actions,contextual,severity,expected_severity,casualties"]
    for i in range(12):
        casualty = i % 2 == 1
        expected = "critical" if casualty else "none"
        # yolo never alarms; rules alarms on every casualty scene and falsely on scene 0
        yolo = "none"
        rules = "critical" if casualty else ("high" if i == 0 else "none")
        rows.append(f"yolo,{0.001 + i * 1e-5:.6f},true,0,false,{yolo},{expected},{int(casualty)}")
        rows.append(f"rules,{0.01 + i * 1e-4:.6f},true,2,true,{rules},{expected},{int(casualty)}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_a_campaign_report_has_correct_severity_missed_casualties_and_false_alarms(tmp_path: Path) -> None:
    report = analyze(str(_records_csv(tmp_path / "results.csv")))
    by_column = {c.column: c for c in report.categorical}
    assert {"correct_severity", "missed_casualty", "false_alarm"} <= set(by_column)

    def rate(column: str, group: str) -> tuple[int, int]:
        r = next(x for x in by_column[column].rates if x.group == group and x.level == "true")
        return r.count, r.n

    assert rate("correct_severity", "yolo") == (6, 12) and rate("correct_severity", "rules") == (11, 12)
    assert rate("missed_casualty", "yolo") == (6, 6) and rate("missed_casualty", "rules") == (0, 6)
    assert rate("false_alarm", "yolo") == (0, 6) and rate("false_alarm", "rules") == (1, 6)
    text = render_markdown(report)
    for label in ("Correct Severity", "Missed Casualties", "False Alarms"):
        assert f"| {label} |" in text


def test_the_mann_whitney_table_shows_u_once_beside_a_median_difference() -> None:
    row = mann_whitney("a", np.array([1.0, 2.0, 3.0, 10.0]), "b", np.array([4.0, 5.0, 6.0]))
    assert row.statistic_name == "U" and row.estimate_name != "U"
    assert row.estimate == np.median([1.0, 2.0, 3.0, 10.0]) - 5.0


def test_the_mann_whitney_table_has_no_duplicated_column(tmp_path: Path) -> None:
    text = render_markdown(analyze(str(_records_csv(tmp_path / "results.csv"))))
    header = next(line for line in text.splitlines() if line.startswith("| pair | ") and "U" in line)
    cells = [c.strip() for c in header.strip("|").split("|")]
    assert len(cells) == len(set(cells)), header
