"""The paper's statistics pipeline on any results file.

>>> from evaluation.stats import analyze
>>> rows = [{"system": s, "latency_s": t + 0.01 * i} for i in range(12) for s, t in (("a", 1.0), ("b", 2.0))]
>>> report = analyze(rows)                          # or a CSV/TSV/JSON/JSONL file; columns detected
>>> report.to_markdown().count("|") > 0, report.to_latex().startswith("%"), report.to_json()[:1]
(True, True, '{')

Modules, one job each: :mod:`readers` (files and records → raw table), :mod:`dataset` (column detection and
parsing), :mod:`descriptive`, :mod:`assumptions` (Shapiro–Wilk, Levene), :mod:`parametric` (ANOVA, Welch,
Tukey HSD, Games–Howell, Cohen's d), :mod:`nonparametric` (Kruskal–Wallis, Dunn, Mann–Whitney U),
:mod:`categorical` (chi-square, Cramér's V, pairwise 2 × L), :mod:`effect_sizes`, :mod:`power`,
:mod:`selection` (the documented test-selection rule), :mod:`pvalues` (bounds instead of 0),
:mod:`pipeline`, :mod:`report`, :mod:`tables`, :mod:`render_markdown`, :mod:`render_latex`, :mod:`cli`.
"""

from __future__ import annotations

from evaluation.stats.cli import main
from evaluation.stats.dataset import CategoricalColumn, ContinuousColumn, Dataset, load_dataset
from evaluation.stats.errors import InputError
from evaluation.stats.models import (
    CategoricalAnalysis,
    ContinuousAnalysis,
    GroupSummary,
    MethodChoice,
    NormalityTest,
    OmnibusResult,
    PairwiseEffect,
    PairwiseResult,
    PosthocResult,
    RateSummary,
    VarianceTest,
)
from evaluation.stats.pipeline import analyze, analyze_dataset
from evaluation.stats.pvalues import PValue
from evaluation.stats.report import StatsReport
from evaluation.stats.selection import RULE_TEXT

__all__ = [
    "RULE_TEXT",
    "CategoricalAnalysis",
    "CategoricalColumn",
    "ContinuousAnalysis",
    "ContinuousColumn",
    "Dataset",
    "GroupSummary",
    "InputError",
    "MethodChoice",
    "NormalityTest",
    "OmnibusResult",
    "PValue",
    "PairwiseEffect",
    "PairwiseResult",
    "PosthocResult",
    "RateSummary",
    "StatsReport",
    "VarianceTest",
    "analyze",
    "analyze_dataset",
    "load_dataset",
    "main",
]
