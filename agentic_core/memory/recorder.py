"""A run's memories, gathered from its event bus while it flies and written to the fleet's memory as they come
(``incremental``: a run killed with ``kill -9`` keeps what it found before the kill) or at its end.

From the events: every incident logged (``incidents.log``), every alert sent (``alerts.notify``), every decision
that saw something or drew on a memory (severity above ``none``, or a memory cited; a ``critical`` one is also
where a casualty was found), and every
operator's approval answer. Each is placed (the subject's position, else the aircraft's at that moment) and keeps
its provenance: run, trace line, mission step, vehicle clock.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from agentic_core.contracts.events import RunEvent
from agentic_core.contracts.feedback import PreferenceFeatures
from agentic_core.contracts.memory import MemoryKind, Provenance

from .fleet import FleetMemory, cited

Place = tuple[float, float] | None
Evidence = Callable[[str], PreferenceFeatures | None]
"""The features of an object as the reasoner last saw it (for an operator's answer about it)."""


@dataclass
class Pending:
    kind: MemoryKind
    key: str
    text: str
    place: Place
    severity: str | None
    provenance: Provenance
    cites: list[str] = field(default_factory=list)
    extra: dict[str, Any] = field(default_factory=dict)


def step_of(key: object) -> str | None:
    """The mission step in an idempotency key ``run:step#pass:attempt.n`` (None when there is none)."""
    if not isinstance(key, str) or key.count(":") < 2:
        return None
    return key.split(":")[-2]


class RunRecorder:
    """Subscribe :meth:`on_event` to a run's bus; call :meth:`flush` when it ends (with ``incremental``, each
    memory is also written in the publishing thread as soon as its event is seen). Thread-safe."""

    def __init__(
        self,
        fleet: FleetMemory,
        run_id: str,
        *,
        aircraft: Callable[[], Place],
        locate: Callable[[str], Place],
        mission: str | None = None,
        scene: str | None = None,
        evidence: Evidence | None = None,
        incremental: bool = False,
    ) -> None:
        self.fleet = fleet
        self.run_id = run_id
        self.aircraft = aircraft
        self.locate = locate
        self.mission = mission
        self.scene = scene
        self.evidence = evidence
        self.incremental = incremental
        self.written: list[str] = []
        """Every memory written so far (``kind/key``), by :meth:`flush` or as it came."""
        self.pending: list[Pending] = []
        self._last: dict[str, Any] = {}  # the last decision's assessment: what an approval that follows is about
        self._lock = threading.Lock()

    def _provenance(self, event: RunEvent, **more: Any) -> Provenance:
        f = event.fields()
        return Provenance(run_id=self.run_id, seq=event.seq, step=step_of(f.get("key")), sim_t=event.sim_t,
                          mission=self.mission, scene=self.scene, **more)  # fmt: skip

    def on_event(self, event: RunEvent) -> None:
        found = self._memories(event)
        if found:
            with self._lock:
                self.pending.extend(found)
            if self.incremental:
                self.flush()

    def _memories(self, event: RunEvent) -> list[Pending]:
        f = event.fields()
        key = f"{self.run_id}:{event.seq}"
        if event.kind == "tool" and f.get("status") == "ok" and f.get("name") in ("incidents.log", "alerts.notify"):
            args = f.get("args") or {}
            if f["name"] == "incidents.log":
                text = f"{args.get('kind', 'incident')}: {args.get('description', '')}"
                return [Pending("incident", key, text, self.aircraft(), args.get("severity"), self._provenance(event))]
            text = f"alert sent: {args.get('subject') or args.get('message') or args.get('text') or 'alert'}"
            return [Pending("alert", key, text, self.aircraft(), args.get("severity"), self._provenance(event))]
        if event.kind == "decision":
            assessment = f.get("assessment") or {}
            severity = assessment.get("severity")
            refs = cited(str(assessment.get("rationale", "")))
            if severity in (None, "none") and not refs:  # nothing seen, nothing remembered: not worth keeping
                return []
            subject = assessment.get("subject_id")
            if subject:
                self._last = assessment
            place = (self.locate(subject) if subject else None) or self.aircraft()
            text = f"{severity}: {assessment.get('rationale', '')} {assessment.get('surrounding_features', '')}".strip()
            prov = self._provenance(event)
            out = [Pending("decision", key, text, place, severity, prov, refs)]
            if severity == "critical":
                who = f"{subject} " if subject else ""
                out.append(Pending("casualty", key, f"casualty {who}found: {assessment.get('rationale', '')}", place,
                                   severity, prov, refs))  # fmt: skip
            return out
        if event.kind == "approval" and "answer" in f:
            request = f.get("request") or {}
            verdict = ("edited" if f.get("edited") else "approved") if f.get("answer") else "declined"
            text = f"operator {verdict}: {request.get('question', '')} {f.get('said') or ''}".strip()
            prov = self._provenance(event, verdict=verdict)
            extra = self._preference(event, request, verdict)
            return [Pending("approval", key, text, self.aircraft(), None, prov, extra=extra)]
        return []

    def _preference(self, event: RunEvent, request: dict[str, Any], verdict: str) -> dict[str, Any]:
        """The answer as a preference record (``{"preference": ...}``), when the evidence it was about is known."""
        f = event.fields()
        args: dict[str, Any] = request["args"] if isinstance(request.get("args"), dict) else {}
        subject = args.get("target_id") or self._last.get("subject_id")
        seen = self.evidence(str(subject)) if self.evidence is not None and subject else None
        if seen is None or f.get("via") == "policy":  # a headless policy's answer is nobody's preference
            return {}
        severity = self._last.get("severity") if self._last.get("subject_id") == subject else None
        features = seen.model_copy(update={"severity": severity or seen.severity})
        said = " ".join(str(x) for x in (f.get("said") or "", f.get("edited") or "") if x)[:2000]
        return {"preference": {"verdict": verdict, "action": str(request.get("action", "")),
                               "step": request.get("step"), "object_id": str(subject), "said": said,
                               "features": features.model_dump(), "run_id": self.run_id, "seq": event.seq}}  # fmt: skip

    def flush(self) -> list[str]:
        """Write what was gathered; the ``kind/key`` of each memory written."""
        with self._lock:
            todo, self.pending = self.pending, []
        written = []
        for p in todo:
            lat, lon = p.place if p.place is not None else (None, None)
            written.append(self.fleet.remember(p.kind, p.key, p.text, lat=lat, lon=lon, severity=p.severity,
                                               provenance=p.provenance, cites=p.cites, **p.extra))  # fmt: skip
        with self._lock:
            self.written.extend(written)
        return written


__all__ = ["RunRecorder", "step_of"]
