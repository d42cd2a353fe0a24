"""The report of one analysis: every number, exportable as JSON, Markdown and LaTeX."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

from evaluation.stats.models import CategoricalAnalysis, ContinuousAnalysis, SkippedColumn


class StatsReport(BaseModel):
    """Everything :func:`evaluation.stats.analyze` computed on a data set."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    source: str
    data_schema: str
    """``decision-records`` (our campaign files), ``generic`` (any table) or ``arrays``."""
    group_column: str
    groups: list[str]
    group_sizes: dict[str, int]
    n_records: int
    alpha: float
    baseline: str | None = None
    """Group used for "speed vs baseline"; ``None`` means the fastest group."""
    rule: str
    paper_methods: str
    continuous: list[ContinuousAnalysis] = Field(default_factory=list)
    categorical: list[CategoricalAnalysis] = Field(default_factory=list)
    skipped: list[SkippedColumn] = Field(default_factory=list)
    notes: list[str] = Field(default_factory=list)
    software: dict[str, str] = Field(default_factory=dict)

    def outcome(self, column: str) -> ContinuousAnalysis | CategoricalAnalysis:
        results: list[ContinuousAnalysis | CategoricalAnalysis] = [*self.continuous, *self.categorical]
        for result in results:
            if result.column == column:
                return result
        raise KeyError(column)

    def to_json(self, indent: int | None = 2) -> str:
        return self.model_dump_json(indent=indent)

    def to_markdown(self) -> str:
        from evaluation.stats.render_markdown import render_markdown

        return render_markdown(self)

    def to_latex(self) -> str:
        from evaluation.stats.render_latex import render_latex

        return render_latex(self)


__all__ = ["StatsReport"]
