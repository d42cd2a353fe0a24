"""Stopping a campaign when its answer is known: ``--stop-at-width W``.

After each finished scene the primary comparison is checked: the mean, over the scenes both systems assessed, of
one system's value of a numeric record field minus another's (paired by scene: every scene is seen by every
system), with its Student-t confidence interval. Once that interval is no wider than ``W`` (and at least
``min_scenes`` scenes are in it), no new scene is started; the scenes already running finish and are kept, and the
campaign completes with the scenes it has. Running the same command again without ``--stop-at-width`` goes on to
every scene.

>>> rule = StopRule(width=0.5, treatment="rules", baseline="yolo", min_scenes=3)
>>> rows = [("s1", "rules", 0.8), ("s1", "yolo", 0.7), ("s2", "rules", 0.9), ("s2", "yolo", 0.7),
...         ("s3", "rules", 0.85), ("s3", "yolo", 0.7)]
>>> check = rule.check((scene, system, {"detection_confidence": v}) for scene, system, v in rows)
>>> check.n, round(check.mean, 3), check.answered
(3, 0.15, True)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator
from scipy import stats

from agentic_core.contracts.errors import InputError

from .records import DecisionRecord

NUMERIC_FIELDS = tuple(
    name
    for name, info in DecisionRecord.model_fields.items()
    if info.annotation in (float, int, float | None, int | None, bool)
)
"""Record fields a stopping rule can compare (numbers and yes/no, read as 0/1)."""


class StopRule(BaseModel):
    """When to stop adding scenes: the ``level`` interval of mean(treatment − baseline) of ``metric`` at most
    ``width`` wide, over at least ``min_scenes`` paired scenes."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    width: float = Field(gt=0.0, description="the widest interval that counts as an answer")
    treatment: str
    baseline: str
    metric: str = "detection_confidence"
    level: float = Field(default=0.95, gt=0.0, lt=1.0)
    min_scenes: int = Field(default=5, ge=2)

    @model_validator(mode="after")
    def _known(self) -> StopRule:
        if self.metric not in NUMERIC_FIELDS:
            known = ", ".join(NUMERIC_FIELDS)
            raise ValueError(f"--stop-metric {self.metric!r} is not a numeric record field; one of: {known}")
        if self.treatment == self.baseline:
            raise ValueError(f"--stop-compare needs two different systems, got {self.treatment!r} twice")
        return self

    def check(self, rows: Iterable[tuple[str, str, Mapping[str, object]]]) -> StopCheck:
        """The interval over ``rows`` of (scene id, system, record fields); scenes missing either system's value
        are left out."""
        values: dict[str, dict[str, float]] = {}
        for scene, system, fields in rows:
            if system in (self.treatment, self.baseline):
                value = fields.get(self.metric)
                if isinstance(value, bool | int | float) and math.isfinite(float(value)):
                    values.setdefault(scene, {})[system] = float(value)
        diffs = [v[self.treatment] - v[self.baseline] for v in values.values() if len(v) == 2]
        return StopCheck.of(self, diffs)

    def check_records(self, records: Iterable[DecisionRecord]) -> StopCheck:
        """:meth:`check` over campaign records."""
        return self.check((r.scene_id, r.system, {self.metric: getattr(r, self.metric)}) for r in records)


class StopCheck(BaseModel):
    """The primary comparison now: scenes paired, mean difference, interval, and whether it answers the rule."""

    model_config = ConfigDict(frozen=True)

    n: int
    mean: float
    low: float
    high: float
    answered: bool

    @property
    def width(self) -> float:
        return self.high - self.low

    @classmethod
    def of(cls, rule: StopRule, diffs: list[float]) -> StopCheck:
        n = len(diffs)
        if n < 2:
            return cls(n=n, mean=diffs[0] if diffs else math.nan, low=-math.inf, high=math.inf, answered=False)
        mean = math.fsum(diffs) / n
        sd = math.sqrt(math.fsum((d - mean) ** 2 for d in diffs) / (n - 1))
        half = float(stats.t.ppf(0.5 + rule.level / 2.0, n - 1)) * sd / math.sqrt(n)
        answered = n >= rule.min_scenes and 2.0 * half <= rule.width
        return cls(n=n, mean=mean, low=mean - half, high=mean + half, answered=answered)

    def text(self, rule: StopRule) -> str:
        return (
            f"{rule.metric} {rule.treatment} − {rule.baseline}: {self.mean:+.4f}, {rule.level:.0%} CI "
            f"[{self.low:+.4f}, {self.high:+.4f}] (width {self.width:.4f} ≤ {rule.width:g}) over {self.n} scenes"
        )


_OPTIONS = {"width": "--stop-at-width", "min_scenes": "--stop-min-scenes", "metric": "--stop-metric"}


def parse_stop_rule(
    width: float | None, compare: str | None, metric: str, min_scenes: int, systems: list[str]
) -> StopRule | None:
    """The rule the command line asks for (``None`` without ``--stop-at-width``); :class:`InputError` naming the
    option. ``compare`` is ``TREATMENT,BASELINE``; by default the second system against the first."""
    if width is None:
        if compare is not None:
            raise InputError("--stop-compare needs --stop-at-width")
        return None
    if compare is None:
        if len(systems) < 2:
            raise InputError("--stop-at-width compares two systems; this campaign has one")
        treatment, baseline = systems[1], systems[0]
    else:
        parts = [p.strip() for p in compare.split(",")]
        if len(parts) != 2 or not all(parts):
            raise InputError(f"--stop-compare {compare!r}: expected TREATMENT,BASELINE, e.g. rules,yolo")
        treatment, baseline = parts
    for name in (treatment, baseline):
        if name not in systems:
            raise InputError(f"--stop-compare: {name!r} is not a system of this campaign ({', '.join(systems)})")
    try:
        return StopRule(width=width, treatment=treatment, baseline=baseline, metric=metric, min_scenes=min_scenes)
    except ValidationError as exc:
        first = exc.errors()[0]
        message = str(first["msg"]).removeprefix("Value error, ")
        if first["loc"]:
            message = f"{_OPTIONS.get(str(first['loc'][0]), first['loc'][0])}: {message}"
        raise InputError(message) from None


__all__ = ["NUMERIC_FIELDS", "StopCheck", "StopRule", "parse_stop_rule"]
