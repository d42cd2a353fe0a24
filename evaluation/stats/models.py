"""Result models of the statistics pipeline (pydantic, so every report exports to JSON).

Numbers that cannot be computed are ``None`` with a ``reason``; no model holds NaN or infinity: every model
turns a non-finite number given to it into ``None``, and a test whose statistic or degrees of freedom are not
finite into one that was not computable, its p-value dropped (a NaN statistic never reaches the report with a
p-value).
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from evaluation.stats.pvalues import PValue

ColumnKind = Literal["continuous", "binary", "categorical"]

NOT_FINITE = "not computable: the statistic is not a finite number (the values are beyond double precision)"


def _finite(x: object) -> bool:
    return not isinstance(x, float) or math.isfinite(x)


def _finite_only(value: object) -> object:
    if isinstance(value, dict):
        return {k: v for k, v in value.items() if _finite(v)}
    return value if _finite(value) else None


def _all_finite(data: dict[str, Any]) -> bool:
    for value in data.values():
        items = value.values() if isinstance(value, dict) else value if isinstance(value, tuple) else (value,)
        if not all(_finite(x) for x in items):
            return False
    return True


class _Model(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    @model_validator(mode="before")
    @classmethod
    def _finite_or_not_computable(cls, data: Any) -> Any:
        if not isinstance(data, dict) or _all_finite(data):
            return data
        out = {k: _finite_only(v) for k, v in data.items()}
        df = data.get("df")
        several = isinstance(df, tuple | list)
        dfs: tuple[object, ...] = tuple(df) if isinstance(df, tuple | list) else (df,)
        if not _finite(data.get("statistic")) or not all(_finite(d) for d in dfs):
            out.update(statistic=None, p=None, reason=NOT_FINITE, df=() if several else None)
            if "p_adjusted" in cls.model_fields:
                out["p_adjusted"] = None
        return out


class GroupSummary(_Model):
    """Descriptive statistics of one group on one continuous outcome (missing values dropped)."""

    group: str
    n: int
    n_missing: int = 0
    mean: float | None = None
    sd: float | None = None
    median: float | None = None
    q1: float | None = None
    q3: float | None = None
    min: float | None = None
    max: float | None = None
    mean_ci_low: float | None = None
    mean_ci_high: float | None = None


class RateSummary(_Model):
    """Count and share of one outcome level in one group, with a Wilson score interval."""

    group: str
    level: str
    n: int
    count: int
    rate: float | None = None
    ci_low: float | None = None
    ci_high: float | None = None
    n_missing: int = 0


class NormalityTest(_Model):
    """Shapiro–Wilk test of one group."""

    group: str
    n: int
    statistic: float | None = None
    p: PValue | None = None
    reason: str | None = None
    """Why the test was not computed, or a caveat on its result."""


class VarianceTest(_Model):
    """Levene's test of equal variances (median-centred, i.e. the Brown–Forsythe variant, by default)."""

    test: str
    statistic: float | None = None
    df: tuple[float, ...] = ()
    p: PValue | None = None
    reason: str | None = None


class OmnibusResult(_Model):
    """A test of all groups at once (ANOVA, Welch's ANOVA, Kruskal–Wallis, chi-square)."""

    test: str
    statistic_name: str
    statistic: float | None = None
    df: tuple[float, ...] = ()
    p: PValue | None = None
    effect_sizes: dict[str, float] = Field(default_factory=dict)
    power: float | None = None
    """Post-hoc (observed) power at the report's alpha, where defined."""
    reason: str | None = None

    @property
    def computable(self) -> bool:
        return self.statistic is not None and self.p is not None


class PairwiseResult(_Model):
    """One pair of groups in a post-hoc family. ``estimate`` and effects are oriented as ``a`` minus ``b``."""

    a: str
    b: str
    estimate_name: str
    estimate: float | None = None
    statistic_name: str
    statistic: float | None = None
    df: float | None = None
    ci_low: float | None = None
    ci_high: float | None = None
    p: PValue | None = None
    p_adjusted: PValue | None = None
    effect_name: str | None = None
    effect: float | None = None
    extra: dict[str, float] = Field(default_factory=dict)
    reason: str | None = None


class PosthocResult(_Model):
    """A family of pairwise comparisons."""

    test: str
    adjustment: str
    """How ``p_adjusted`` controls the family-wise error (``"Holm"``), or how ``p`` already does."""
    comparisons: list[PairwiseResult]
    reason: str | None = None


class PairwiseEffect(_Model):
    """Standardised mean difference of a pair (a minus b): Cohen's d with the pooled SD, and Hedges' g."""

    a: str
    b: str
    cohen_d: float | None = None
    hedges_g: float | None = None
    reason: str | None = None


class MethodChoice(_Model):
    """Which test the documented rule chose, why, and what the paper chose."""

    omnibus: str
    posthoc: str
    effect_size: str
    reasons: list[str]
    paper_choice: str
    paper_rule_outcome: str
    """What the paper's stated rule would give on these data."""


class ContinuousAnalysis(_Model):
    column: str
    label: str
    unit: str | None = None
    groups: list[GroupSummary]
    normality: list[NormalityTest]
    homogeneity: VarianceTest
    anova: OmnibusResult
    welch_anova: OmnibusResult
    kruskal: OmnibusResult
    tukey: PosthocResult
    games_howell: PosthocResult
    dunn: PosthocResult
    mann_whitney: PosthocResult
    effect_sizes: list[PairwiseEffect]
    decision: MethodChoice
    notes: list[str] = Field(default_factory=list)

    def chosen_omnibus(self) -> OmnibusResult:
        return {
            self.anova.test: self.anova,
            self.welch_anova.test: self.welch_anova,
            self.kruskal.test: self.kruskal,
        }[self.decision.omnibus]

    def chosen_posthoc(self) -> PosthocResult:
        families = (self.tukey, self.games_howell, self.dunn, self.mann_whitney)
        return next(f for f in families if f.test == self.decision.posthoc)


class CategoricalAnalysis(_Model):
    column: str
    label: str
    kind: ColumnKind
    levels: list[str]
    positive_level: str | None = None
    """For a binary outcome, the level whose rate is reported (``true``)."""
    groups: list[str]
    table: list[list[int]]
    """Observed counts, one row per group (in ``groups`` order), one column per level."""
    rates: list[RateSummary]
    chi_square: OmnibusResult
    expected_min: float | None = None
    expected_below_5: float | None = None
    """Share of cells with an expected count below 5."""
    pairwise: PosthocResult
    decision: MethodChoice
    notes: list[str] = Field(default_factory=list)


class SkippedColumn(_Model):
    column: str
    reason: str


__all__ = [
    "NOT_FINITE",
    "CategoricalAnalysis",
    "ColumnKind",
    "ContinuousAnalysis",
    "GroupSummary",
    "MethodChoice",
    "NormalityTest",
    "OmnibusResult",
    "PairwiseEffect",
    "PairwiseResult",
    "PosthocResult",
    "RateSummary",
    "SkippedColumn",
    "VarianceTest",
]
