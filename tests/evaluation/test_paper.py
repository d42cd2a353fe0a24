"""The paper's figures data file and the reproduction of its statistics from summary figures alone."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from scipy import stats as st

from evaluation.paper import VERDICTS, load_figures, main, reproduce, summary

from .conftest import close, num, pv

REPO = Path(__file__).resolve().parents[2]


def _paper_tex() -> Path | None:
    candidates = [
        os.environ.get("AGENTIC_UAVS_PAPER", ""),
        str(REPO / "paper" / "agentic_uavs.tex"),
        str(REPO.parent / "shared" / "paper" / "agentic_uavs.tex"),  # where CI and developers keep shared/
    ]
    return next((Path(c) for c in candidates if c and Path(c).is_file()), None)


def test_every_figure_has_a_source_line() -> None:
    figs = load_figures()
    ids = [f.id for f in figs.figures]
    assert len(ids) == len(set(ids)) and len(ids) >= 80
    assert all(f.where.line > 0 and f.where.section and f.printed for f in figs.figures)


def test_printed_text_is_on_the_referenced_line() -> None:
    tex = _paper_tex()
    if tex is None:
        pytest.skip("paper source not found (set AGENTIC_UAVS_PAPER=path/to/agentic_uavs.tex)")
    lines = tex.read_text(encoding="utf-8").splitlines()
    for f in load_figures().figures:
        assert f.printed in lines[f.where.line - 1], f.id


def _sample(mean: float, sd: float, n: int, seed: int) -> np.ndarray:
    """n values with exactly this mean and SD."""
    z = np.random.default_rng(seed).normal(size=n)
    z = (z - z.mean()) / z.std(ddof=1)
    return np.asarray(mean + sd * z, dtype=np.float64)


def test_summary_anova_and_tukey_equal_scipy_on_data_with_those_moments() -> None:
    figs = load_figures()
    groups = ("yolo", "gemma", "gpt4")
    means = [figs.value(f"pt.{g}.mean") for g in groups]
    sds = [figs.value(f"pt.{g}.sd") for g in groups]
    data = [_sample(m, s, 44, i) for i, (m, s) in enumerate(zip(means, sds, strict=True))]
    ours = summary.anova(list(groups), [44] * 3, means, sds)
    assert close(ours.statistic, st.f_oneway(*data).statistic)
    assert close(ours.statistic, 513.6748772396786)
    # detection confidence with the pooled SD implied by F = 3.96 (moderate p-values, where Tukey is exact)
    conf = [figs.value(f"conf.{g}") for g in groups]
    grand = sum(conf) / 3
    sd = float(np.sqrt(44 * sum((m - grand) ** 2 for m in conf) / 2 / 3.96))
    tukey = summary.tukey(list(groups), [44] * 3, conf, [sd] * 3)
    ref = st.tukey_hsd(*[_sample(m, sd, 44, 10 + i) for i, m in enumerate(conf)])
    assert close(pv(tukey.comparisons[1].p), ref.pvalue[0, 2])
    assert close(summary.anova_f([44] * 3, conf, [sd] * 3), 3.96)


def test_chi_square_reproduced_by_counts_2_35_41() -> None:
    result = summary.chi_square([2, 35, 41], [44] * 3, ["yolo", "gemma", "gpt4"])
    table = np.array([[42, 2], [9, 35], [3, 41]])
    assert close(result.statistic, st.chi2_contingency(table, correction=False).statistic)
    assert round(num(result.statistic), 2) == 82.92
    assert (2, 35, 41) in summary.binary_tables_with_chi2(82.92, 0.01, 44, 3)


def test_counts_for_rate() -> None:
    assert summary.counts_for_rate(0.75, 44, 0.01) == ([33], [])
    assert summary.counts_for_rate(0.79, 44, 0.01) == ([], [35])  # 79.5% is truncated, not rounded
    assert summary.counts_for_rate(0.92, 44, 0.01) == ([], [])


def test_verdicts() -> None:
    rep = reproduce()
    verdict = {r.figure_id: r.verdict for r in rep.rows}
    assert set(verdict.values()) <= set(VERDICTS)
    assert verdict["pt.anova.F"] == "consistent"  # 513.67; the rounding box of the inputs contains 514.0
    assert verdict["pt.anova.p"] == "reproduced" and verdict["power_processing_time"] == "reproduced"
    assert verdict["pt.tukey"] == "reproduced" and verdict["pt.speedup"] == "reproduced"
    assert verdict["conf.anova.F"] == "not reproducible" and verdict["conf.anova.p"] == "reproduced"
    assert verdict["chi2.value"] == "discrepant" and verdict["chi2.V"] == "reproduced"
    assert verdict["arr.gpt4"] == "discrepant" and verdict["arr.gemma"] == "consistent"
    assert verdict["methods.mann_whitney"] == "not reproducible"
    assert verdict["t3.infra.gpt4"] == "not reproducible"
    data_ids = {f.id for f in load_figures().figures if f.role != "input"}
    assert data_ids <= set(verdict), data_ids - set(verdict)
    assert "2/35/41" in rep.row("chi2.value").recomputed
    counts = rep.counts()
    assert sum(counts.values()) == len(rep.rows)


@pytest.mark.parametrize("fmt", ["text", "markdown", "json"])
def test_main_formats(fmt: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--format", fmt]) == 0
    out = capsys.readouterr().out
    if fmt == "json":
        assert len(json.loads(out)["rows"]) == len(reproduce().rows)
    else:
        assert "not reproducible" in out and "82.92" in out


def test_main_out_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "paper.md"
    assert main(["--format", "markdown", "--out", str(target)]) == 0
    assert target.read_text().startswith("# Reproducing the paper")
    assert main(["--out", str(tmp_path / "missing" / "x.md")]) == 2
    assert "cannot write" in capsys.readouterr().err
    assert main(["--format", "pdf"]) == 2
