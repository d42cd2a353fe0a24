"""A run's link to the fleet's memory (``agentic-uav run --memory FILE``): the reasoner is told what earlier runs
found near where the aircraft is (cited in its rationale, used as priors), and what this run finds is recorded
as it happens (a run killed with ``kill -9`` keeps it; ``--resume`` records the rest). A run without ``--memory``
has none of this and behaves as before.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from ..agent.bus import EventBus
from ..contracts.feedback import PreferenceFeatures
from ..contracts.memory import MemoryKind, Provenance, RecallPort, Recollection
from ..contracts.world_model import WorldModel
from ..memory.feedback import FeedbackError, FeedbackModel
from ..memory.fleet import FleetMemory
from ..memory.knowledge import search_knowledge
from ..memory.recorder import Place, RunRecorder
from ..reasoning.model_reasoners import model_of
from ..reasoning.reasoners import Reasoner
from ..reasoning.remembering import Remembering
from ..reasoning.rules import RuleReasoner

if TYPE_CHECKING:
    from flight.sim.scene_model import Scene

    from ..contracts.policy_graph import PolicyGraph
    from .settings import RunSettings

RECALL_M = 200.0
"""How far from the aircraft a memory is still "near here"."""
AREA_M = 5000.0
"""How far from home a memory still belongs to the area the start of a run reports on."""


def aircraft(view: dict[str, Any]) -> Place:
    """Where the aircraft is, from its telemetry view (None before the first sample)."""
    lat, lon = view.get("lat_deg"), view.get("lon_deg")
    return (float(lat), float(lon)) if isinstance(lat, int | float) and isinstance(lon, int | float) else None


class RunMemory:
    """Opened by the runner when ``settings.memory`` is set: wrap the reasoner, subscribe, announce, record."""

    def __init__(self, path: Path, run_id: str, *, view: Callable[[], dict[str, Any]], locate: Callable[[str], Place],
                 mission: str, scene: str | None) -> None:  # fmt: skip
        path.parent.mkdir(parents=True, exist_ok=True)
        self.fleet = FleetMemory(path)
        self.run_id = run_id
        self.world: WorldModel | None = None  # the last World Model assessed: the evidence an answer is about
        self.recorder = RunRecorder(self.fleet, run_id, aircraft=lambda: aircraft(view()), locate=locate,
                                    mission=mission, scene=scene, evidence=self.evidence, incremental=True)  # fmt: skip
        self.feedback_error: str | None = None
        try:
            self.feedback = FeedbackModel.load(self.fleet)
        except FeedbackError as exc:  # a broken record must not ground the fleet: the rules' table stands
            self.feedback, self.feedback_error = FeedbackModel.fit([]), str(exc)

    def evidence(self, object_id: str) -> PreferenceFeatures | None:
        """What the reasoner last saw of an object (for the operator's answer about it)."""
        return PreferenceFeatures.of(self.world, object_id) if self.world is not None else None

    def examples(self, world: WorldModel, focus: str | None = None) -> list[Recollection]:
        """The few-shot port: past answers about evidence like the focus's (else the stillest person's)."""
        people = sorted(world.objects_of("person"), key=lambda o: -o.stationary_s)
        subject = focus or (people[0].id if people else None)
        seen = PreferenceFeatures.of(world, subject, severity="critical") if subject else None
        return self.feedback.examples(seen) if seen is not None and self.feedback.records else []

    def recall(self, world: WorldModel, focus: str | None = None) -> list[Recollection]:
        """The context port: earlier runs' memories within :data:`RECALL_M` of the aircraft, the operator's
        answers there included."""
        self.world = world
        ego = world.ego_pose
        kinds: tuple[MemoryKind, ...] = ("incident", "casualty", "alert", "decision", "approval")
        return self.fleet.recall(ego.lat, ego.lon, within_m=RECALL_M, kinds=kinds, exclude_run=self.run_id)

    def knowledge(self, topics: list[str]) -> RecallPort:
        """The knowledge port for a mission's ``knowledge:`` topics: the passages still valid, most relevant first
        (one search per topic, each passage once)."""

        def passages(world: WorldModel, focus: str | None = None) -> list[Recollection]:
            found: dict[str, Recollection] = {}
            for topic in topics:
                for item in search_knowledge(self.fleet.store, topic, limit=2):
                    value = item.value
                    found.setdefault(item.key, Recollection(
                        key=item.key, kind="knowledge", text=str(value.get("text", "")),
                        provenance=Provenance(source=value.get("source"), version=value.get("version"),
                                              valid_until=value.get("valid_until")),
                    ))  # fmt: skip
            return list(found.values())

        return passages

    def wrap(self, reasoner: Reasoner, topics: list[str] | None = None) -> Reasoner:
        model = model_of(reasoner)
        if topics and model is not None:
            model.knowledge = self.knowledge(topics)
        rules = reasoner if isinstance(reasoner, RuleReasoner) else getattr(reasoner, "rules", None)
        if self.feedback.records and isinstance(rules, RuleReasoner):
            rules.prior = self.feedback
        if self.feedback.records and model is not None:
            model.examples = self.examples
        return Remembering(reasoner, self.recall)

    def start(self, bus: EventBus, home: tuple[float, float] | None) -> None:
        """Subscribe the recorder, and say in the trace what the memory holds of this area and how it searches."""
        bus.subscribe(self.recorder.on_event)
        known = self.fleet.recall(*home, within_m=AREA_M, limit=1000, exclude_run=self.run_id) if home else []
        runs = sorted({r.provenance.run_id for r in known if r.provenance.run_id})
        bus.publish("memory", event="recalled", store=str(self.fleet.path), search=self.fleet.search_mode,
                    memories=[f"{r.kind}/{r.key}" for r in known], runs=runs,
                    feedback=len(self.feedback.records), feedback_error=self.feedback_error,
                    summary=f"{len(known)} memories of this area from {len(runs)} earlier runs "
                    f"({self.fleet.search_mode}); {len(self.feedback.records)} operator answers as priors"
                    + (f" ({self.feedback_error}: not used)" if self.feedback_error else ""))  # fmt: skip

    def finish(self, bus: EventBus) -> None:
        """Record what is left of what this run found (before its end event), say all it recorded, close the store."""
        try:
            self.recorder.flush()
            written = list(self.recorder.written)
            bus.publish("memory", event="recorded", memories=written,
                        summary=f"recorded {len(written)} memories of this run")  # fmt: skip
        finally:
            self.fleet.close()


def start_memory(memory: RunMemory | None, knowledge: list[str] | None, bus: EventBus,
                 home: Callable[[], tuple[float, float] | None]) -> None:  # fmt: skip
    """Start the run's memory; without one, a mission's ``knowledge:`` would be silently unread: say so."""
    if memory is not None:
        memory.start(bus, home())
    elif knowledge:
        bus.publish("log", level="warning", event="knowledge_unused", topics=list(knowledge),
                    summary=f"the mission declares knowledge: {', '.join(knowledge)}; without --memory nothing is "
                    "looked up (ingest documents with agentic-uav memory ingest, run with --memory FILE)")  # fmt: skip


class _Run(Protocol):
    """What :func:`with_memory` reads of a :class:`~agentic_core.run.runner.MissionRun`."""

    settings: RunSettings
    run_id: str
    plan: PolicyGraph
    scene: Scene | None

    def view(self) -> dict[str, Any]: ...

    def _target(self, object_id: str) -> tuple[float, float] | None: ...


def with_memory(run: _Run, reasoner: Reasoner) -> tuple[RunMemory | None, Reasoner]:
    """The run's memory and its reasoner wrapped to remember; ``(None, reasoner)`` without ``--memory``."""
    if run.settings.memory is None:
        return None, reasoner
    memory = RunMemory(run.settings.memory, run.run_id, view=run.view, locate=run._target, mission=run.plan.plan_id,
                       scene=run.scene.id if run.scene else None)  # fmt: skip
    return memory, memory.wrap(reasoner, run.plan.knowledge)
