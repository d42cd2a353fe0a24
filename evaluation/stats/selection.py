"""The documented rule that picks the primary test, and the paper's own choice beside it.

Rule for a continuous outcome (alpha is the report's significance level, 0.05 by default):

1. Normality: Shapiro–Wilk in every group. Normality holds when every group has n >= 3, is not constant,
   and has p >= alpha. A group where the test cannot run counts as "not shown normal".
2. If normality holds and Levene's test (median-centred) has p >= alpha: one-way ANOVA, Tukey HSD,
   eta² and Cohen's d / Hedges' g.
3. If normality holds but Levene's p < alpha (or Levene cannot run): Welch's ANOVA and Games–Howell.
4. Otherwise: Kruskal–Wallis, Dunn's test with Holm's correction, and pairwise Mann–Whitney U (Holm) with
   the rank-biserial correlation.

All the tests are computed and reported whichever is chosen; the rule decides which one the summary tables
show. With very large groups Shapiro–Wilk rejects normality for trivial departures, so large data sets go
to step 4 — the rank tests remain valid there.

Rule for a categorical outcome: chi-square test of independence with Cramér's V, then pairwise 2 × L
chi-square tests with Holm's correction (Fisher's exact p alongside for 2 × 2 tables).

The paper (§IV-C, lines 325 and 330) states: one-way ANOVA with Tukey HSD; Mann–Whitney U where normality
fails; chi-square of independence for categorical outcomes; Cohen's d and rank-biserial r as effect sizes;
Shapiro–Wilk and Levene as checks at alpha = 0.05.
"""

from __future__ import annotations

from collections.abc import Sequence

from evaluation.stats.categorical import CHI_SQUARE, PAIRWISE_CHI_SQUARE
from evaluation.stats.models import MethodChoice, NormalityTest, VarianceTest
from evaluation.stats.nonparametric import DUNN, KRUSKAL, MANN_WHITNEY
from evaluation.stats.parametric import ANOVA, GAMES_HOWELL, TUKEY, WELCH
from evaluation.stats.pvalues import format_p

RULE_TEXT = (
    "Continuous outcomes: if Shapiro–Wilk does not reject normality in any group (p ≥ α, every group n ≥ 3 "
    "and not constant) and Levene's test (median-centred) does not reject equal variances, one-way ANOVA "
    "with Tukey HSD; if normality holds but variances differ, Welch's ANOVA with Games–Howell; otherwise "
    "Kruskal–Wallis with Dunn's test (Holm) and pairwise Mann–Whitney U with rank-biserial r. "
    "Categorical outcomes: chi-square test of independence with Cramér's V, pairwise chi-square with Holm's "
    "correction. All tests are computed and reported; the rule picks the one shown in the summary tables."
)

PAPER_CONTINUOUS = f"{ANOVA} + {TUKEY}, Cohen's d (§IV-C l.325); {MANN_WHITNEY} where normality fails"
PAPER_CATEGORICAL = f"{CHI_SQUARE}, Cramér's V (§IV-C l.325; §IV-D l.369)"


def choose_continuous(
    normality: Sequence[NormalityTest], homogeneity: VarianceTest, alpha: float = 0.05
) -> MethodChoice:
    """Apply the rule in this module's docstring."""
    reasons: list[str] = []
    not_normal = [t for t in normality if t.p is not None and t.p.value < alpha]
    untestable = [t for t in normality if t.p is None]
    normal = not not_normal and not untestable
    if not_normal:
        detail = ", ".join(f"{t.group} (W = {t.statistic:.3f}, p = {format_p(t.p)})" for t in not_normal if t.p)
        reasons.append(f"Shapiro–Wilk rejects normality at α = {alpha:g} in {detail}")
    if untestable:
        detail = ", ".join(f"{t.group}: {t.reason}" for t in untestable)
        reasons.append(f"normality cannot be checked in {detail}")
    if normal:
        reasons.append(f"Shapiro–Wilk does not reject normality in any group at α = {alpha:g}")
    paper_rule = f"{ANOVA} + {TUKEY}" if normal else f"{MANN_WHITNEY} (normality not shown)"
    if not normal:
        return MethodChoice(
            omnibus=KRUSKAL,
            posthoc=DUNN,
            effect_size="rank-biserial r (pairwise Mann–Whitney U), eta²_H",
            reasons=reasons,
            paper_choice=PAPER_CONTINUOUS,
            paper_rule_outcome=paper_rule,
        )
    if homogeneity.p is not None and homogeneity.p.value >= alpha:
        reasons.append(f"Levene does not reject equal variances (p = {format_p(homogeneity.p)})")
        return MethodChoice(
            omnibus=ANOVA,
            posthoc=TUKEY,
            effect_size="eta², Cohen's d / Hedges' g",
            reasons=reasons,
            paper_choice=PAPER_CONTINUOUS,
            paper_rule_outcome=paper_rule,
        )
    if homogeneity.p is None:
        reasons.append(f"Levene's test cannot run ({homogeneity.reason}): equal variances not shown")
    else:
        reasons.append(f"Levene rejects equal variances (p = {format_p(homogeneity.p)})")
    return MethodChoice(
        omnibus=WELCH,
        posthoc=GAMES_HOWELL,
        effect_size="eta², Cohen's d / Hedges' g",
        reasons=reasons,
        paper_choice=PAPER_CONTINUOUS,
        paper_rule_outcome=paper_rule,
    )


def choose_categorical() -> MethodChoice:
    return MethodChoice(
        omnibus=CHI_SQUARE,
        posthoc=PAIRWISE_CHI_SQUARE,
        effect_size="Cramér's V",
        reasons=["categorical outcome"],
        paper_choice=PAPER_CATEGORICAL,
        paper_rule_outcome=CHI_SQUARE,
    )


__all__ = ["PAPER_CATEGORICAL", "PAPER_CONTINUOUS", "RULE_TEXT", "choose_categorical", "choose_continuous"]
