"""Tier 2: the reasoner's say on an event a trigger's rule found, asked once per trigger and object. Only a
``high`` or ``critical`` assessment lets the trigger act.

An object whose track was lost just now (a person lying still is missed for a few frames) is looked at again for
up to ``look_again_s`` of the vehicle's clock before it is judged, rather than judged on a stale track; and an
``analyze_scene`` that must be sure (``min_confidence``) looks again as long, and judges once more, before an
unsure assessment fails it. While the reasoner thinks, simulated time runs at real time
(:class:`~agentic_core.agent.pacing.Pace`), so a slow model costs the flight what it would cost a real one.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from ..mission.model import Trigger
from ..mission.triggers import object_id
from ..perception.world_model import WorldModel
from ..reasoning.assessment import Assessment, Decision
from .pacing import Pace
from .ports import Publish, ReasonerPort, VehicleView, WorldSource

ACT_AT = ("high", "critical")
"""Assessments that let a trigger's sub-plan run."""


def acts(assessment: Assessment | None) -> bool:
    """Whether an assessment lets a trigger's sub-plan run (:data:`ACT_AT`); a failed one does not."""
    return assessment is not None and assessment.severity in ACT_AT


class Gate:
    """The reasoner as the trigger gate and as the ``analyze_scene`` tool; remembers every verdict it gave."""

    def __init__(
        self,
        reasoner: ReasonerPort,
        world: WorldSource,
        vehicle: VehicleView,
        publish: Publish,
        pace: Pace,
        *,
        look_again_s: float = 2.0,
        on_decision: Callable[[WorldModel, Decision], None] | None = None,
    ) -> None:
        self.reasoner = reasoner
        self.world = world
        self.vehicle = vehicle
        self.publish = publish
        self.pace = pace
        self.look_again_s = look_again_s
        self.on_decision = on_decision
        self.last: Decision | None = None
        self.decisions = 0
        self._lock = threading.Lock()
        self._verdicts: dict[tuple[str, str | None], Assessment | None] = {}
        self._asking: dict[tuple[str, str | None], threading.Lock] = {}

    # ---- verdicts ----

    def known(self, trigger: str, event: Any) -> bool:
        """Whether the reasoner was already asked about this trigger's event."""
        with self._lock:
            return (trigger, object_id(event)) in self._verdicts

    def assessment(self, trigger: str, event: Any) -> Assessment | None:
        with self._lock:
            return self._verdicts.get((trigger, object_id(event)))

    def __call__(self, trigger: Trigger, event: Any) -> bool:
        """The gate (``Environment.gate``): whether ``trigger`` may act on ``event``; asks the reasoner once."""
        key = (trigger.id, object_id(event))
        with self._lock:
            asking = self._asking.setdefault(key, threading.Lock())
        with asking:  # a second thread asking about the same object waits for the first one's answer
            with self._lock:
                if key in self._verdicts:
                    return acts(self._verdicts[key])
            decision = self.decide(key[1], f"trigger {trigger.id}")
            with self._lock:
                self._verdicts[key] = decision.assessment
        act = acts(decision.assessment)
        self.publish("trigger", trigger=trigger.id, event=key[1], act=act,
                     summary=f"{trigger.id} on {key[1]}: {'act' if act else 'no action'}")  # fmt: skip
        return act

    # ---- asking the reasoner ----

    def decide(self, focus: str | None, why: str) -> Decision:
        """Assess the scene (or one object of it), publish the decision and remember it as the last one."""
        if focus is not None:
            focus, world = self._look_again(focus)
        else:
            world = self.world.world
        with self.pace.waiting("model"):
            decision = self.reasoner.assess(world, focus)
        with self._lock:
            self.last = decision
            self.decisions += 1
        if self.on_decision is not None:
            self.on_decision(world, decision)
        verdict = decision.assessment.severity if decision.assessment else f"failed ({decision.error})"
        self.publish("decision", why=why, focus=focus, **decision.model_dump(mode="json"),
                     summary=f"{decision.reasoner} on {focus or 'the scene'}: {verdict}")  # fmt: skip
        return decision

    def confident(self, focus: str | None, why: str, min_confidence: float) -> Decision:
        """:meth:`decide`; when the assessment counts persons at a confidence under ``min_confidence``, watch for
        up to ``look_again_s`` more of the vehicle's clock — until a frame shows ``focus`` that sure — and decide
        once more, so that one unsure moment of the detector (a passer-by over a casualty, a glint) does not fail a
        confirmation alone. The last decision."""
        decision = self.decide(focus, why)
        low = unsure(decision, min_confidence)
        if low is None:
            return decision
        self.publish("log", level="info", focus=focus, summary=f"confidence {low:.2f} is under the "
                     f"{min_confidence:.2f} asked for: looking again for {self.look_again_s:g} s")  # fmt: skip

        def sure() -> bool:
            found = self.world.world.get(self.world.resolve(focus) or focus) if focus is not None else None
            return found is not None and found.conf >= min_confidence

        self._watch(sure)
        return self.decide(focus, f"{why}, looked again")

    def _reidentified(self, focus: str) -> str:
        """``focus``, or the id its object is tracked under now (published when it changed)."""
        now = self.world.resolve(focus)
        if now is not None and now != focus:
            self.publish("log", level="info", focus=focus, now=now, summary=f"{focus} is tracked again as {now}")
            return now
        return focus

    def _look_again(self, focus: str) -> tuple[str, WorldModel]:
        """The object to judge and the World Model to judge it on: ``focus`` (or the id it is tracked under now);
        when its track is lost just now, look again for up to ``look_again_s`` of the vehicle's clock (and at most
        that plus a second of wall time)."""
        focus = self._reidentified(focus)
        world = self.world.world
        found = world.get(focus)
        if found is None or found.state != "lost":
            return focus, world

        def back() -> bool:
            nonlocal world, found
            world = self.world.world
            found = world.get(focus)
            return found is None or found.state != "lost"

        self._watch(back)
        seen = found is not None and found.state != "lost"
        self.publish("log", level="info", summary=f"looked again at {focus}: {'seen' if seen else 'still not seen'}")
        return focus, world

    def _watch(self, enough: Callable[[], bool]) -> None:
        """Let frames come for up to ``look_again_s`` of the vehicle's clock (and at most that plus a second of wall
        time), until ``enough()``."""
        until_sim = self.vehicle.clock() + self.look_again_s
        until_wall = time.monotonic() + self.look_again_s + 1.0
        with self.pace.waiting("vehicle"):  # waiting on frames: the simulation may run at full speed
            while self.vehicle.clock() < until_sim and time.monotonic() < until_wall:
                time.sleep(0.005)  # frames come from the vehicle's thread; a short poll is the wait
                if enough():
                    return


def unsure(decision: Decision, min_confidence: float) -> float | None:
    """The assessment's confidence when it counts persons at less than ``min_confidence`` (what fails an
    ``analyze_scene``); else None."""
    assessment = decision.assessment
    if assessment is None or not assessment.persons_detected or assessment.confidence >= min_confidence:
        return None
    return assessment.confidence


__all__ = ["ACT_AT", "Gate", "acts", "unsure"]
