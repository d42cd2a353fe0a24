"""Operator feedback that changes decisions: every approve, decline and edit a run records (an ``approval`` memory
carrying a :class:`~agentic_core.contracts.feedback.Preference`) is fitted by a logistic model of P(approve) on
the evidence, which moves the rules' stillness threshold (:meth:`FeedbackModel.shift`, the rules' ``ThresholdPort``)
and picks the most similar past answers as few-shot examples for the model (:meth:`FeedbackModel.examples`).

The rules are the prior: the fit sees their own table as light pseudo-answers (approve when an isolated person has
been still ``still_s`` or more), so with no answer the threshold does not move, and each real answer pulls it.

>>> from agentic_core.contracts.feedback import Preference, PreferenceFeatures
>>> seen = PreferenceFeatures(severity="critical", confidence=0.8, stationary_s=12.0, isolation_m=30.0)
>>> no = Preference(verdict="declined", action="land", features=seen)
>>> FeedbackModel.fit([]).shift(seen), FeedbackModel.fit([no, no]).shift(seen) > 1.0
(0.0, True)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import ValidationError

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.feedback import Preference, PreferenceFeatures
from agentic_core.contracts.memory import Provenance, Recollection

from .fleet import ROOT, FleetMemory

PRIOR_WEIGHT = 0.25
"""Weight of each of the rules' pseudo-answers (48 of them: about twelve real answers' worth in all)."""
RIDGE = 0.001
"""L2 penalty of the fit: keeps it finite when the answers separate perfectly (they usually do)."""
MAX_RECORDS = 5000
"""Preference records read at most (the oldest first)."""
NAMES = ("intercept", "stillness (per 10 s)", "isolation (per 30 m)", "confidence")


class FeedbackError(InputError):
    """A preference record that cannot be used: its key and the field that is wrong."""


def row(f: PreferenceFeatures) -> list[float]:
    """The model's inputs for one piece of evidence (scaled to order one; not isolated counts as 0 m)."""
    return [1.0, f.stationary_s / 10.0, min(f.isolation_m or 0.0, 300.0) / 30.0, f.confidence]


def preference_of(key: str, value: Any) -> Preference:
    """The preference an ``approval`` memory carries; :class:`FeedbackError` naming the key and field if absurd."""
    try:
        return Preference.model_validate(value)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "record"
        raise FeedbackError(f"preference {key}: field {where}: {first['msg']} (got {first.get('input')!r})") from None


def prior_rows(still_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The rules' table as pseudo-answers: approve iff isolated and still for ``still_s`` or more."""
    grid = [PreferenceFeatures(severity="high", confidence=0.8, stationary_s=float(s), isolation_m=iso)
            for s in range(0, 32, 2) for iso in (None, 15.0, 40.0)]  # fmt: skip
    x = np.array([row(f) for f in grid])
    y = np.array([1.0 if f.isolation_m and f.stationary_s >= still_s else 0.0 for f in grid])
    return x, y


def _fit(x: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    import statsmodels.api as sm

    model = sm.GLM(y, x, family=sm.families.Binomial(), freq_weights=w)
    return np.asarray(model.fit_regularized(alpha=RIDGE, L1_wt=0.0).params, dtype=float)


@dataclass
class FeedbackModel:
    """P(approve | evidence), fitted to the operators' answers over the rules' prior."""

    params: np.ndarray
    prior: np.ndarray
    still_s: float
    records: list[tuple[Recollection, Preference]] = field(default_factory=list)

    @classmethod
    def fit(cls, answers: Sequence[Preference | tuple[Recollection, Preference]], still_s: float = 10.0
            ) -> FeedbackModel:  # fmt: skip
        """Fit to ``answers`` (bare, or with the memory each came from, for few-shot examples)."""
        pairs = [a if isinstance(a, tuple) else (_recollection(a), a) for a in answers]
        px, py = prior_rows(still_s)
        pw = np.full(len(py), PRIOR_WEIGHT)
        prior = _fit(px, py, pw)
        if not pairs:
            return cls(prior, prior, still_s, [])
        x = np.vstack([px, [row(p.features) for _, p in pairs]])
        y = np.concatenate([py, [1.0 if p.approved else 0.0 for _, p in pairs]])
        w = np.concatenate([pw, np.ones(len(pairs))])
        return cls(_fit(x, y, w), prior, still_s, pairs)

    @classmethod
    def load(cls, fleet: FleetMemory, still_s: float = 10.0) -> FeedbackModel:
        """Fit to every believed preference record of the fleet's memory."""
        pairs = []
        for item in fleet.store.search((ROOT, "approval"), limit=MAX_RECORDS):
            if "preference" in item.value:
                prov = Provenance.model_validate(item.value.get("provenance", {}))
                pref = preference_of(f"approval/{item.key}", item.value["preference"])
                pairs.append((Recollection(key=item.key, kind="approval", text=str(item.value.get("text", "")),
                                           provenance=prov), pref))  # fmt: skip
        return cls.fit(pairs, still_s)

    def p_approve(self, f: PreferenceFeatures) -> float:
        """The probability that an operator approves acting on this evidence."""
        z = float(np.dot(self.params, row(f)))
        return 1.0 / (1.0 + math.exp(-max(min(z, 50.0), -50.0)))

    def shift(self, f: PreferenceFeatures) -> float:
        """Seconds the answers move the stillness threshold for this evidence (0 with no answer): where the fitted
        P(approve) crosses one half, against where the rules' prior alone puts it."""
        if not self.records:
            return 0.0
        fitted, prior = _half(self.params, f), _half(self.prior, f)
        if fitted is None or prior is None:
            return 0.0
        return max(min(fitted - prior, 3 * self.still_s), -self.still_s)

    def __call__(self, features: PreferenceFeatures, /) -> float:
        return self.shift(features)

    def examples(self, f: PreferenceFeatures, k: int = 3) -> list[Recollection]:
        """The ``k`` past answers about the most similar evidence (a different class or severity counts as far)."""

        def gap(p: PreferenceFeatures) -> float:
            a, b = np.array(row(p)[1:]), np.array(row(f)[1:])
            return float(np.linalg.norm(a - b)) + 5.0 * (p.object_class != f.object_class) + (p.severity != f.severity)

        ranked = sorted(self.records, key=lambda rp: (gap(rp[1].features), rp[0].key))
        return [_example(r, p) for r, p in ranked[:k]]

    def describe(self) -> list[str]:
        """The fitted model, for ``agentic-uav memory feedback``."""
        verdicts = [p.verdict for _, p in self.records]
        counts = ", ".join(f"{verdicts.count(v)} {v}" for v in ("approved", "declined", "edited"))
        terms = " + ".join(f"{b:+.3f}·{n}" for b, n in zip(self.params, NAMES, strict=True))
        lines = [f"{len(self.records)} operator answers ({counts}); prior: the rules (still_s {self.still_s:g} s, "
                 f"{len(prior_rows(self.still_s)[1])} pseudo-answers of weight {PRIOR_WEIGHT:g}); ridge {RIDGE:g}",
                 f"logit P(approve) = {terms}"]  # fmt: skip
        lines.append("isolated 30 m, confidence 0.8:  still  P(approve)  threshold shift")
        for s in (5.0, 10.0, 15.0, 20.0):
            f = PreferenceFeatures(severity="critical", confidence=0.8, stationary_s=s, isolation_m=30.0)
            lines.append(f"{'':33}{s:4.0f} s  {self.p_approve(f):10.2f}  {self.shift(f):+.1f} s")
        return lines


def _half(params: np.ndarray, f: PreferenceFeatures) -> float | None:
    """The stillness (s) at which P(approve) is one half for ``f``'s other features; None if stillness does not
    raise it."""
    b = params
    if b[1] <= 1e-6:
        return None
    rest = float(b[0] + b[2] * row(f)[2] + b[3] * f.confidence)
    return -10.0 * rest / float(b[1])


def _recollection(p: Preference) -> Recollection:
    key = f"{p.run_id or 'given'}:{p.seq if p.seq is not None else 0}"
    return Recollection(key=key, kind="approval", text=f"operator {p.verdict}: {p.action} {p.said}".strip(),
                        provenance=Provenance(run_id=p.run_id, seq=p.seq, step=p.step, verdict=p.verdict))  # fmt: skip


def _example(r: Recollection, p: Preference) -> Recollection:
    f = p.features
    iso = f"{f.isolation_m:.0f} m from the crowd" if f.isolation_m is not None else "in the crowd"
    text = (f"{f.object_class} still {f.stationary_s:.0f} s, {iso}, confidence {f.confidence:.2f}, assessed "
            f"{f.severity}: the operator {p.verdict} {p.action or 'the action'}"
            + (f" ({p.said})" if p.said else ""))  # fmt: skip
    return r.model_copy(update={"text": text})


__all__ = ["FeedbackError", "FeedbackModel", "preference_of", "prior_rows", "row"]
