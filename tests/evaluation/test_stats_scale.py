"""Values at the edges of double precision (1e-320 to 1.7e308): the tests, which do not depend on the unit, give
the same statistics as on ordinary values, the descriptives come out in the data's unit, and no statistic that is
not a finite number is ever reported (least of all with a tiny p-value)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from evaluation.stats import analyze, main, parametric
from evaluation.stats.dataset import Dataset
from evaluation.stats.models import NOT_FINITE, OmnibusResult, PairwiseResult
from evaluation.stats.pvalues import PValue
from evaluation.stats.report import StatsReport

BASE = {"A": [1.0, 2.0, 3.0, 2.5, 1.5], "B": [4.0, 5.0, 6.5, 5.5, 4.5], "C": [2.0, 3.5, 3.0, 2.0, 4.0]}


def _report(groups: dict[str, list[float]], scale: float = 1.0, shift: float = 0.0) -> StatsReport:
    data = {g: np.asarray(v) * scale + shift for g, v in groups.items()}
    return analyze(Dataset.from_groups(data))


def _statistics(report: StatsReport) -> list[float | None]:
    (c,) = report.continuous
    out = [c.anova.statistic, c.welch_anova.statistic, c.kruskal.statistic, c.homogeneity.statistic]
    out += [n.statistic for n in c.normality]
    for family in (c.tukey, c.games_howell, c.dunn, c.mann_whitney):
        out += [p.statistic for p in family.comparisons]
    out += [e.cohen_d for e in c.effect_sizes]
    return out


def _ps(report: StatsReport) -> list[float]:
    (c,) = report.continuous
    tests = [c.anova, c.welch_anova, c.kruskal]
    ps = [t.p.value for t in tests if t.p is not None]
    for family in (c.tukey, c.games_howell, c.dunn, c.mann_whitney):
        ps += [p.p.value for p in family.comparisons if p.p is not None]
    return ps


@pytest.mark.parametrize("scale", [1e-320, 1e-310, 1e-300, 1e-160, 1e150, 1e160, 1e200, 1e300])
def test_the_tests_do_not_depend_on_the_size_of_the_values(scale: float) -> None:
    base, scaled = _report(BASE), _report(BASE, scale)
    tol = 1e-3 if abs(scale) < 1e-307 else 1e-9  # subnormal inputs carry only a few digits themselves
    expected = _statistics(base)
    got = _statistics(scaled)
    if scale < 0:  # mirrored data: signed statistics change sign, the rest does not
        expected, got = [abs(x) for x in expected if x is not None], [abs(x) for x in got if x is not None]
    assert None not in got and got == pytest.approx(expected, rel=tol, abs=1e-9)
    assert _ps(scaled) == pytest.approx(_ps(base), rel=tol, abs=1e-12)
    (b,), (s,) = base.continuous, scaled.continuous
    for gb, gs in zip(b.groups, s.groups, strict=True):
        assert gs.mean == pytest.approx(gb.mean * scale, rel=tol, abs=0)  # type: ignore[operator]
        assert gs.sd == pytest.approx(gb.sd * abs(scale), rel=tol, abs=0)  # type: ignore[operator]
    for pb, ps in zip(b.tukey.comparisons, s.tukey.comparisons, strict=True):
        assert ps.ci_low is not None and ps.ci_high is not None and pb.ci_low is not None and pb.ci_high is not None
        assert sorted([ps.ci_low, ps.ci_high]) == pytest.approx(
            sorted([pb.ci_low * scale, pb.ci_high * scale]), rel=tol
        )


def test_values_spanning_the_whole_range_and_mixed_signs_give_finite_results() -> None:
    groups = {"A": [-1e300, 2e-300, 3e299, -5e-320], "B": [1e-10, -4e300, 6e300, 7e300], "C": [1e-320, 0.0, 2e300, 1.0]}
    report = _report(groups)
    _assert_no_unfinished_number(report)
    (c,) = report.continuous
    assert c.kruskal.statistic is not None and c.anova.statistic is not None and c.welch_anova.statistic is not None
    assert [g.mean for g in c.groups] == pytest.approx([math.fsum(v) / 4 for v in groups.values()], rel=1e-12)


def test_one_huge_outlier_is_analysed_not_refused() -> None:
    groups = {"A": [1.0, 2.0, 3.0, 2.0, 1e300], "B": [4.0, 5.0, 6.0, 5.0, 4.0]}
    report = _report(groups)
    _assert_no_unfinished_number(report)
    (c,) = report.continuous
    assert c.groups[0].max == 1e300 and c.groups[0].median == 2.0
    assert c.groups[1].sd == pytest.approx(float(np.std(groups["B"], ddof=1)), rel=1e-12)  # B's own scale
    assert c.normality[1].statistic == pytest.approx(
        _report({"B": groups["B"], "C": [1, 2, 3]}).continuous[0].normality[0].statistic
    )
    assert c.kruskal.computable and c.kruskal.p == _report(groups, 1e-300).continuous[0].kruskal.p
    # B's variance is 1e-600 of A's: no double holds both, and Welch's F says so rather than call B constant
    assert c.welch_anova.reason == NOT_FINITE and c.welch_anova.p is None
    assert c.decision.omnibus == "Kruskal–Wallis"  # the outlier breaks normality, as it would at any scale


def test_values_near_the_largest_double_leave_out_only_what_overflows(tmp_path: Path) -> None:
    path = tmp_path / "huge.csv"
    rows = ["group,value", "A,1e308", "A,-1e308", "A,1.5e308", "B,1.7e308", "B,-1.7e308", "B,1e308"]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    report = analyze(path)
    _assert_no_unfinished_number(report)
    (c,) = report.continuous
    assert c.anova.statistic == pytest.approx(
        _report({"A": [1, -1, 1.5], "B": [1.7, -1.7, 1]}).continuous[0].anova.statistic
    )
    assert c.groups[1].min == -1.7e308 and c.groups[1].max == 1.7e308
    assert c.groups[0].mean_ci_low is None  # ± t·SD/√n is beyond the largest double
    assert any("exceed the largest double" in n for n in c.notes)


@pytest.mark.parametrize("name", ["big160", "e200", "huge", "tiny"])
def test_the_command_reports_edge_values_with_exit_0_and_no_nan(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    scale = {"big160": 1e160, "e200": 1e200, "huge": 2.5e307, "tiny": 1e-320}[name]
    path = tmp_path / f"{name}.csv"
    values = [("A", 1.0), ("A", 2.0), ("A", 3.0), ("B", 4.0), ("B", 5.0), ("B", 6.5)]
    path.write_text("group,value\n" + "".join(f"{g},{v * scale!r}\n" for g, v in values), encoding="utf-8")
    assert main([str(path), "--format", "json"]) == 0
    out = capsys.readouterr().out
    data = json.loads(out, parse_constant=_refuse)
    anova = data["continuous"][0]["anova"]
    assert anova["statistic"] == pytest.approx(11.6491, rel=1e-3) and anova["p"]["value"] == pytest.approx(
        0.027, abs=1e-3
    )


def _refuse(constant: str) -> Any:
    raise AssertionError(f"{constant} in the JSON report")


def _assert_no_unfinished_number(report: StatsReport) -> None:
    """No NaN or infinity anywhere, and no p-value beside a missing statistic."""
    data = json.loads(report.to_json(), parse_constant=_refuse)
    for analysis in data["continuous"]:
        for key in ("anova", "welch_anova", "kruskal", "homogeneity"):
            assert analysis[key]["p"] is None or analysis[key]["statistic"] is not None
        for family in ("tukey", "games_howell", "dunn", "mann_whitney"):
            for pair in analysis[family]["comparisons"]:
                assert pair["p"] is None or pair["statistic"] is not None


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_statistic_that_is_not_finite_is_never_reported_with_a_p_value(bad: float) -> None:
    tiny = PValue(value=2.2e-308, bound="upper")
    omnibus = OmnibusResult(test="t", statistic_name="F", statistic=bad, df=(1.0, 4.0), p=tiny, effect_sizes={"x": bad})
    assert (omnibus.statistic, omnibus.p, omnibus.reason, omnibus.effect_sizes) == (None, None, NOT_FINITE, {})
    welch = OmnibusResult(test="t", statistic_name="F", statistic=3.0, df=(1.0, bad), p=tiny)
    assert welch.p is None and not welch.computable
    pair = PairwiseResult(
        a="A", b="B", estimate_name="d", estimate=bad, statistic_name="q", statistic=bad, p=tiny, p_adjusted=tiny
    )
    assert (pair.estimate, pair.statistic, pair.p, pair.p_adjusted, pair.reason) == (None, None, None, None, NOT_FINITE)


def test_moments_beyond_double_precision_are_not_computable() -> None:
    groups = [parametric.Moments("A", 3, 1e160, 1e320), parametric.Moments("B", 3, 5e160, math.inf)]
    with np.errstate(all="ignore"):
        results = [parametric.one_way_anova(groups), parametric.welch_anova(groups)]
        tukey, games_howell = parametric.tukey_hsd(groups), parametric.games_howell(groups)
    assert all(r.p is None and r.reason for r in results)
    assert tukey.reason == NOT_FINITE and all(c.p is None for c in games_howell.comparisons)
