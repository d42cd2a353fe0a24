"""Any reasoner, told what earlier runs found near here: the memories reach it through the context port
(:class:`~agentic_core.contracts.memory.RecallPort`), are cited in the assessment's rationale, and act as priors.

The prior: a person standing still within ``prior_m`` of where a casualty was found before is worth a look
(severity ``high``, ``approach_and_confirm``) even when the scene alone would not say so. A memory that fails to
load never costs the decision: the reasoner's own assessment stands.

>>> from agentic_core.contracts.memory import Provenance, Recollection
>>> from agentic_core.perception.world_model import WorldModel
>>> from agentic_core.reasoning.rules import RuleReasoner
>>> world = WorldModel.model_validate({"timestamp": 5.0, "ego_pose": {"north": 0, "east": 0, "down": -30,
...     "lat": 21.4133, "lon": 39.8933, "alt": 30}, "objects": [{"id": "P-2", "class": "person", "conf": 0.8,
...     "stationary_s": 3.0, "pose": {"north": 4, "east": 0, "down": 0, "lat": 21.41334, "lon": 39.8933, "alt": 0}}]})
>>> seen = Recollection(key="R1:20", kind="casualty", text="casualty P-9 found", lat=21.41336, lon=39.8933,
...                     provenance=Provenance(run_id="R1", seq=20))
>>> a = Remembering(RuleReasoner(), lambda w, f: [seen]).assess(world).assessment
>>> a.severity, a.subject_id, "[memory casualty/R1:20]" in a.rationale
('high', 'P-2', True)
"""

from __future__ import annotations

from typing import Any

from agentic_core.contracts.geodesy import distance_m
from agentic_core.contracts.memory import RecallPort, Recollection
from agentic_core.contracts.world_model import WorldModel

from .assessment import Assessment, Decision
from .reasoners import Reasoner
from .rules import persons

CITED = 3  # memories named in one rationale, nearest first
STILL_S = 1.0  # how long a person must have stood still for the prior to apply


def _where(r: Recollection) -> str:
    p = r.provenance
    parts = [f"run {p.run_id}" if p.run_id else None, f"step {p.step}" if p.step else None,
             f"t={p.sim_t:.0f} s" if p.sim_t is not None else None]  # fmt: skip
    away = f" {r.distance_m:.0f} m away" if r.distance_m is not None else ""
    return f"{r.kind} '{r.text}'{away} ({', '.join(x for x in parts if x)}) {r.cite()}"


class Remembering:
    """Wraps a reasoner (same ``name``, same answers when nothing is remembered near the scene)."""

    def __init__(self, inner: Reasoner, recall: RecallPort, *, prior_m: float = 25.0) -> None:
        self.inner = inner
        self.recall = recall
        self.prior_m = prior_m
        self.name = inner.name

    def __getattr__(self, attr: str) -> Any:  # the model side reads the inner reasoner's client and counters
        return getattr(self.inner, attr)

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        decision = self.inner.assess(world, focus)
        if decision.assessment is None:
            return decision
        try:
            memories = self.recall(world, focus)
        except Exception:  # a memory that cannot be read must not cost the decision
            return decision
        if not memories:
            return decision
        amended = self.amend(world, decision.assessment, memories)
        return decision.model_copy(update={"assessment": amended})

    def amend(self, world: WorldModel, a: Assessment, memories: list[Recollection]) -> Assessment:
        """``a`` with the memories cited in its rationale, and raised to ``high`` by a remembered casualty's prior."""
        update: dict[str, Any] = {}
        remembered = "Remembered near here: " + "; ".join(_where(r) for r in memories[:CITED]) + "."
        prior = self._prior(world, memories) if a.severity in (None, "none", "low") else None
        if prior is not None:
            person, casualty = prior
            update |= {"severity": "high", "recommended_actions": ["approach_and_confirm"], "subject_id": person,
                       "rationale": f"{person} is standing still where a casualty was found before "
                       f"{casualty.cite()}; worth a look. {a.rationale}".strip()}  # fmt: skip
        update["rationale"] = f"{update.get('rationale', a.rationale)} {remembered}".strip()
        return Assessment.model_validate({**a.model_dump(), **update})

    def _prior(self, world: WorldModel, memories: list[Recollection]) -> tuple[str, Recollection] | None:
        casualties = [m for m in memories if m.kind == "casualty" and m.lat is not None and m.lon is not None]
        for person in sorted(persons(world), key=lambda p: -p.stationary_s):
            if person.stationary_s < STILL_S or person.pose.lat is None or person.pose.lon is None:
                continue
            for m in casualties:
                if distance_m(person.pose.lat, person.pose.lon, m.lat or 0.0, m.lon or 0.0) <= self.prior_m:
                    return person.id, m
        return None


__all__ = ["Remembering"]
