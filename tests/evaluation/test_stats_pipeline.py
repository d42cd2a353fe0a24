"""The whole analysis: the rule's choices, edge cases, and the three export formats."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from evaluation.stats import Dataset, InputError, StatsReport, analyze
from evaluation.stats.models import CategoricalAnalysis, ContinuousAnalysis
from evaluation.stats.nonparametric import KRUSKAL
from evaluation.stats.parametric import ANOVA, GAMES_HOWELL, TUKEY, WELCH

from .conftest import pv, pval

RNG_SEED = 7


def _normal(means: list[float], sds: list[float], n: int = 40) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(RNG_SEED)
    return {f"g{i}": rng.normal(m, s, n) for i, (m, s) in enumerate(zip(means, sds, strict=True))}


def _continuous(report: StatsReport) -> ContinuousAnalysis:
    return report.continuous[0]


def test_rule_picks_anova_welch_or_kruskal() -> None:
    equal = _continuous(analyze(Dataset.from_groups(_normal([0, 0.5, 1], [1, 1, 1]))))
    assert (equal.decision.omnibus, equal.decision.posthoc) == (ANOVA, TUKEY)
    unequal = _continuous(analyze(Dataset.from_groups(_normal([0, 0.5, 1], [1, 4, 9]))))
    assert (unequal.decision.omnibus, unequal.decision.posthoc) == (WELCH, GAMES_HOWELL)
    rng = np.random.default_rng(RNG_SEED)
    skewed = _continuous(analyze(Dataset.from_groups({k: rng.lognormal(0, 1.5, 60) for k in "abc"})))
    assert skewed.decision.omnibus == KRUSKAL and skewed.chosen_posthoc().test.startswith("Dunn")
    assert "Mann–Whitney" in skewed.decision.paper_rule_outcome
    for result in (equal, unequal, skewed):
        assert result.decision.paper_choice.startswith("one-way ANOVA + Tukey HSD")


def test_a_constant_group() -> None:
    data = _normal([1, 2], [1, 1], 20) | {"flat": np.full(20, 3.0)}
    result = _continuous(analyze(Dataset.from_groups(data)))
    flat = next(t for t in result.normality if t.group == "flat")
    assert flat.p is None and "equal" in (flat.reason or "")
    assert result.decision.omnibus == KRUSKAL  # normality cannot be shown for the constant group
    assert result.anova.statistic is not None
    assert result.welch_anova.statistic is None and "zero-variance" in (result.welch_anova.reason or "")
    assert any("constant" in n for n in result.notes)


def test_every_group_constant() -> None:
    result = _continuous(analyze(Dataset.from_groups({"a": [1.0] * 5, "b": [2.0] * 5, "c": [3.0] * 4})))
    assert result.anova.statistic is None and "within-group variance" in (result.anova.reason or "")
    assert result.tukey.comparisons == [] and result.tukey.reason
    assert result.kruskal.statistic is not None  # the ranks still separate the groups
    assert all(e.cohen_d is None and e.reason for e in result.effect_sizes)


def test_tiny_and_unequal_groups() -> None:
    result = _continuous(analyze(Dataset.from_groups({"one": [1.0], "two": [2.0, 2.5], "many": list(np.arange(9.0))})))
    assert [g.n for g in result.groups] == [1, 2, 9]
    assert all(t.p is None for t in result.normality[:2])
    assert result.anova.statistic is not None and result.tukey.comparisons
    gh_one = next(c for c in result.games_howell.comparisons if c.a == "one")
    assert gh_one.p is None and "at least 2" in (gh_one.reason or "")
    assert result.welch_anova.statistic is None


def test_nans_are_dropped_and_counted() -> None:
    data = {"a": [1.0, np.nan, 2.0, 3.0], "b": [4.0, 5.0, np.nan, np.nan, 6.5], "c": [np.nan, np.nan]}
    result = _continuous(analyze(Dataset.from_groups(data)))
    assert [(g.n, g.n_missing) for g in result.groups] == [(3, 1), (3, 2), (0, 2)]
    assert any("left out" in n for n in result.notes) and any("5 missing" in n for n in result.notes)
    assert [c.a for c in result.tukey.comparisons] == ["a"]


def test_zero_cell_categorical_and_records(tmp_path: Path) -> None:
    records = [
        {"system": s, "processing_time_s": t, "n_actions": a, "contextual": c, "person_detected": True}
        for s, t, a, c in [("yolo", 3e-5, 0, False)] * 10 + [("llm", 2.0, 2, True)] * 8 + [("llm", 2.5, 0, False)] * 2
    ]
    report = analyze(records)
    arr = report.outcome("action_recommended")
    assert isinstance(arr, CategoricalAnalysis)
    assert arr.table == [[10, 0], [2, 8]]
    assert arr.chi_square.statistic is not None and arr.rates[0].rate == 0.0
    persons = report.outcome("person_detected")
    assert isinstance(persons, CategoricalAnalysis) and persons.chi_square.statistic is None


def test_exports(tmp_path: Path) -> None:
    report = analyze(_records_csv(tmp_path))
    text = report.to_json()
    assert "NaN" not in text and "Infinity" not in text
    assert StatsReport.model_validate_json(text) == report
    data = json.loads(text)
    assert data["continuous"][0]["anova"]["p"]["value"] > 0
    md = report.to_markdown()
    for needle in (
        "## Table 2 layout",
        "## Table 3 layout",
        "Sample Size (n)",
        "Speed vs. yolo",
        "Test selection rule",
    ):
        assert needle in md
    tex = report.to_latex()
    assert tex.count(r"\begin{table}") == tex.count(r"\end{table}") == 3
    assert tex.count("{") == tex.count("}")
    assert r"$\pm$" in tex and r"\toprule" in tex


def test_bad_alpha_and_baseline(tmp_path: Path) -> None:
    path = _records_csv(tmp_path)
    with pytest.raises(ValueError, match="alpha"):
        analyze(path, alpha=1.5)
    with pytest.raises(InputError, match="baseline 'nope' is not a group"):
        analyze(path, baseline="nope")


def test_large_separation_prints_bounds(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    report = analyze(Dataset.from_groups({"a": rng.normal(0, 1, 5000), "b": rng.normal(50, 1, 5000)}))
    result = _continuous(report)
    assert result.kruskal.p is not None and pval(result.kruskal.p).is_bound
    assert "< " in report.to_markdown()
    assert all(c.p is not None and pv(c.p) > 0 for c in result.mann_whitney.comparisons)


def _records_csv(tmp_path: Path) -> Path:
    rng = np.random.default_rng(RNG_SEED)
    lines = ["scene_id,system,processing_time_s,detection_confidence,person_detected,n_actions,contextual,error"]
    for system, mean, sd, p_act in [
        ("yolo", 29.5e-6, 9.4e-6, 0.0),
        ("gemma", 1.48, 0.58, 0.8),
        ("gpt4", 4.95, 1.15, 0.9),
    ]:
        for i in range(44):
            t = abs(rng.normal(mean, sd))
            lines.append(
                f"s{i},{system},{t!r},{min(1.0, abs(rng.normal(0.75, 0.1))):.3f},{rng.random() < 0.8},"
                f"{int(rng.random() < p_act) * 2},{rng.random() < p_act},"
            )
    path = tmp_path / "campaign.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_time_formatting_in_table2(tmp_path: Path) -> None:
    md = analyze(_records_csv(tmp_path)).to_markdown()
    row = next(line for line in md.splitlines() if line.startswith("| Processing Time"))
    assert "µs" in row and " s |" in row
    assert not math.isnan(1.0)
