"""One scene through one or more systems: a fixed observation, perception, periodic assessments, one record each.

**The observation protocol.** The camera (:class:`~flight.camera.CameraSpec`: 84° × 51°, 1920×1080, 30 Hz, looking
straight down from a stabilised gimbal) hovers ``altitude_m`` (30 m) above the scene's *point of interest*, heading
north, for ``frames`` frames (360: 12 s, past the rule reasoner's 10 s stillness threshold). The point of
interest is the first isolated casualty of the ground truth, else its first casualty, else the centre of the densest
populated crowd zone (the mean of its corners), else the mean position of the scene's persons, else home. The scene
moves in 30 Hz steps (:class:`~flight.sim.scene.SceneState`); each frame goes through the simulated detector
(:class:`~flight.sim.detector.SimulatedDetector`) and perception
(:class:`~agentic_core.perception.pipeline.Perception`, which knows the scene's landmarks — shade, tents, the
medical post — as a map would tell it). With ``render`` on, the camera is the rendering one
(:func:`~flight.sim.render.camera.rendering_camera`: 640×480, same field of view and rate) and every frame carries
its pixels for a detector that reads them.

**Assessments.** Every system assesses the World Model every ``assess_every`` frames (30: once a simulated second;
0: only at the end) and at the final frame; the final decision is the record's. Every system reads the same World
Model: the detector's noise is seeded from (campaign seed, scene id) alone, so a scene's perception is identical
for every system (a paired comparison) and a record is the same whether its system ran alone or beside others.
The systems themselves draw no random numbers (a model's sampling aside; requests use temperature 0).

**Ground truth**, measured at the final frame unless said otherwise:

* *persons in view*: persons whose body box is at least half inside the image (the detector's own test);
* *detection tp/fp/fn*: the World Model's confirmed person tracks matched one-to-one (Hungarian, least total
  distance) to the persons in view whose true ground position is within ``match_gate_m`` (2 m) of the track's —
  tracks, not raw detections, since tracks are what every system reads; unmatched tracks are false positives,
  unmatched persons misses;
* *casualty in view*: a casualty's true ground position projects inside the image at some frame;
* *time to intervention*: simulation time from the first frame a casualty is in view to the first decision of
  severity ``critical`` whose ``subject_id`` names it (the subject's track lies within ``match_gate_m`` of that
  casualty); ``None`` when no casualty is ever in view or no such decision comes. Its resolution is the assessment
  interval.

>>> from flight.sim.scene_gen import generate_scene
>>> from evaluation.campaign.systems import SystemSpec
>>> scene = generate_scene(3, persons=40, casualties=1, distractors=0)
>>> (rules,) = run_episode(scene, [SystemSpec(name="rules", kind="rules")], EpisodeSettings(frames=360))
>>> rules.severity, rules.expected_severity, round(rules.time_to_intervention_s, 2)
('critical', 'critical', 10.97)
"""

from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from agentic_core.perception.metrics import TrackingScore
from agentic_core.perception.pipeline import Perception
from agentic_core.perception.world_model import WorldModel
from agentic_core.reasoning.assessment import Decision
from agentic_core.reasoning.reasoners import Reasoner
from agentic_core.reasoning.rules import RuleSettings
from agentic_core.run.detector_choice import needs_pixels, parse_detector, pixel_detector
from flight.camera import CameraPose, CameraSpec, Frame, project_points
from flight.sim.detector import SimulatedCamera, SimulatedDetector
from flight.sim.render.camera import rendering_camera
from flight.sim.scene import SceneState
from flight.sim.scene_model import Scene

from .records import DecisionRecord
from .systems import ClientFactory, SystemSpec, build_reasoner

DEFAULT_GOAL = "Patrol the Hajj crowd from the air and get help to anyone who needs it."


class EpisodeSettings(BaseModel):
    """How every episode of a campaign observes its scene and assesses it (the manifest records these)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    frames: int = Field(default=360, ge=1, le=100_000, description="camera frames (30 Hz): 360 is 12 s")
    altitude_m: float = Field(default=30.0, gt=2.0, le=500.0, description="hover height above the point of interest")
    assess_every: int = Field(default=30, ge=0, description="frames between assessments; 0: only the final frame")
    match_gate_m: float = Field(default=2.0, gt=0.0, description="track-to-truth matching distance")
    still_s: float = Field(default=10.0, gt=0.0, description="the rule reasoner's stillness threshold")
    landmarks: bool = Field(default=True, description="perception knows the scene's landmarks")
    goal: str = Field(default=DEFAULT_GOAL, description="the mission goal a model is told")
    camera: CameraSpec = Field(default_factory=CameraSpec)
    render: bool = Field(
        default=False,
        exclude_if=lambda on: not on,  # off: the settings, and so every job's id, are as before rendering existed
        description="the camera renders 640×480 pixels (flight.sim.render) instead of the camera above",
    )
    detector: str = Field(
        default="sim",
        exclude_if=lambda choice: choice == "sim",  # as for render: job ids of sim campaigns unchanged
        description="sim, ours or onnx:PATH (the last two render the camera)",
    )

    @field_validator("detector")
    @classmethod
    def _known_detector(cls, value: str) -> str:
        return parse_detector(value)

    @property
    def duration_s(self) -> float:
        return self.frames / self.camera.rate_hz


def derive_seed(*parts: object) -> int:
    """A 63-bit seed from any parts, the same in every process and Python version (SHA-256 of their text).

    >>> derive_seed(0, "gen-1", "perception") == derive_seed(0, "gen-1", "perception")
    True
    """
    digest = hashlib.sha256("\x1f".join(str(p) for p in parts).encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") >> 1


def perception_seed(campaign_seed: int, scene_id: str) -> int:
    """The seed of a scene's detector noise: the same for every system of the campaign."""
    return derive_seed(campaign_seed, scene_id, "perception")


def point_of_interest(scene: Scene) -> tuple[float, float, str]:
    """Where the camera hovers (north, east) and what is there (see the module docs)."""
    gt = scene.ground_truth
    for ident in (*gt.isolated, *gt.casualties):
        actor = scene.actor(ident)
        return actor.position.north, actor.position.east, f"casualty {ident}"
    zones = [z for z in scene.zones if z.persons > 0]
    if zones:
        zone = max(zones, key=lambda z: z.density)
        north, east = zone.vertices().mean(axis=0)
        return float(north), float(east), f"crowd zone {zone.id}"
    people = [a.position for a in scene.actors if a.class_name == "person"]
    if people:
        return sum(p.north for p in people) / len(people), sum(p.east for p in people) / len(people), "persons"
    return 0.0, 0.0, "home"


@dataclass
class _Run:
    """One system's state over an episode."""

    system: SystemSpec
    reasoner: Reasoner | None
    close: Callable[[], None]
    build_error: str | None = None
    last: Decision | None = None
    last_time_s: float = 0.0
    assessments: int = 0
    llm_calls: int = 0
    tokens: int = 0
    time_s: float = 0.0
    model_s: float = 0.0
    intervention_s: float | None = None

    def assess(self, world: WorldModel) -> Decision:
        """One assessment; its time and its model's time add to the episode's (a reused answer costs what its
        lookup costs, its model call having been counted when it was made)."""
        decision = self._assess(world)
        self.time_s += decision.processing_time_s
        self.model_s += decision.model_time_s
        return decision

    def _assess(self, world: WorldModel) -> Decision:
        start = time.perf_counter()
        if self.reasoner is None:
            return Decision(reasoner=self.system.name, assessment=None, processing_time_s=0.0, error=self.build_error)
        try:
            decision = self.reasoner.assess(world)
        except Exception as exc:  # a system that fails gives an error record, never a crashed campaign
            elapsed = time.perf_counter() - start
            return Decision(
                reasoner=self.reasoner.name,
                assessment=None,
                processing_time_s=elapsed,
                error=f"{type(exc).__name__}: {exc}",
            )
        self.llm_calls += decision.llm_calls
        self.tokens += decision.prompt_tokens + decision.completion_tokens
        return decision


def run_episode(
    scene: Scene,
    systems: Sequence[SystemSpec],
    settings: EpisodeSettings | None = None,
    campaign_seed: int = 0,
    *,
    clients: ClientFactory | None = None,
    wrap: Callable[[SystemSpec, Reasoner], Reasoner] | None = None,
) -> list[DecisionRecord]:
    """Observe ``scene`` as the module docs say and return one record per system, in ``systems`` order;
    ``clients`` builds the model clients (see :func:`~evaluation.campaign.systems.build_reasoner`); ``wrap``
    amends each built reasoner (a study's prior, a recorder)."""
    cfg = settings or EpisodeSettings()
    rules = RuleSettings(still_s=cfg.still_s)
    seed = perception_seed(campaign_seed, scene.id)
    state = SceneState(scene)
    detector = SimulatedDetector(state, seed=seed)
    rendered = cfg.render or needs_pixels(cfg.detector)
    camera = (
        rendering_camera(state, seed, like=SimulatedCamera(cfg.camera)) if rendered else SimulatedCamera(cfg.camera)
    )
    pixels = pixel_detector(cfg.detector, detector, seed=seed)
    north, east, _ = point_of_interest(scene)
    pose = CameraPose(north_m=north, east_m=east, down_m=-cfg.altitude_m)
    home = scene.home
    perception = Perception(
        home=(home.lat_deg, home.lon_deg, home.alt_msl_m), landmarks=scene.landmarks if cfg.landmarks else ()
    )
    runs = [_start(system, rules, cfg.goal, clients) for system in systems]
    for run in runs:
        if wrap is not None and run.reasoner is not None:
            run.reasoner = wrap(run.system, run.reasoner)
    casualties = list(scene.ground_truth.casualties)
    first_in_view: dict[str, float] = {}
    perception_time = 0.0
    frame: Frame | None = None
    world: WorldModel | None = None
    try:
        for k in range(cfg.frames):
            t = k / cfg.camera.rate_hz
            frame = camera.capture(pose, t)
            frame, detections = pixels.see(frame) if pixels is not None else (frame, detector.detect(frame))
            start = time.perf_counter()
            world = perception.update(frame, detections)
            perception_time += time.perf_counter() - start
            truth = _casualty_positions(state, casualties)
            for ident in _in_image(camera.spec, pose, truth):
                first_in_view.setdefault(ident, t)
            final = k == cfg.frames - 1
            if final or (cfg.assess_every and (k + 1) % cfg.assess_every == 0):
                for run in runs:
                    decision = run.assess(world)
                    run.last, run.last_time_s = decision, t
                    run.assessments += 1
                    if run.intervention_s is None:
                        named = _named_casualty(decision, world, truth, cfg.match_gate_m)
                        if named is not None:
                            run.intervention_s = t - first_in_view.setdefault(named, t)
    finally:
        for run in runs:
            run.close()
    assert frame is not None and world is not None  # frames >= 1
    tp, fp, fn, in_view = _detection_counts(detector, frame, world, cfg.match_gate_m)
    gt = scene.ground_truth
    common = {
        "scene_id": scene.id,
        "perception_time_s": perception_time,
        "frames": cfg.frames,
        "seed": seed,
        "expected_severity": gt.expected_severity,
        "casualties": len(gt.casualties),
        "isolated_casualties": len(gt.isolated),
        "casualty_in_view": bool(first_in_view),
        "persons_in_view": in_view,
        "detection_tp": tp,
        "detection_fp": fp,
        "detection_fn": fn,
    }
    return [_record(run, common) for run in runs]


def _start(system: SystemSpec, rules: RuleSettings, goal: str, clients: ClientFactory | None) -> _Run:
    try:
        reasoner, close = build_reasoner(system, rules=rules, goal=goal, clients=clients)
    except Exception as exc:  # e.g. the API key left the environment: error records for this system
        return _Run(system, None, lambda: None, build_error=f"{type(exc).__name__}: {exc}")
    return _Run(system, reasoner, close)


def _casualty_positions(state: SceneState, casualties: Sequence[str]) -> dict[str, tuple[float, float]]:
    out = {}
    for ident in casualties:
        row = state.index_of(ident)
        out[ident] = (float(state.positions[row, 0]), float(state.positions[row, 1]))
    return out


def _in_image(spec: CameraSpec, pose: CameraPose, points: dict[str, tuple[float, float]]) -> list[str]:
    """The ids whose ground position projects inside the image."""
    if not points:
        return []
    ids = list(points)
    ground = np.array([[n, e, 0.0] for n, e in points.values()])
    _, visible = project_points(spec, pose, ground)
    return [ident for ident, seen in zip(ids, visible.tolist(), strict=True) if seen]


def _named_casualty(
    decision: Decision, world: WorldModel, truth: dict[str, tuple[float, float]], gate_m: float
) -> str | None:
    """The casualty a critical decision names: its subject's track within ``gate_m`` of one (the nearest)."""
    a = decision.assessment
    if a is None or a.severity != "critical" or a.subject_id is None or not truth:
        return None
    subject = world.get(a.subject_id)
    if subject is None:
        return None
    distance, ident = min(
        (math.hypot(n - subject.pose.north, e - subject.pose.east), ident) for ident, (n, e) in truth.items()
    )
    return ident if distance <= gate_m else None


def _detection_counts(
    detector: SimulatedDetector, frame: Frame, world: WorldModel, gate_m: float
) -> tuple[int, int, int, int]:
    """Confirmed person tracks against the persons in view at ``frame``: (tp, fp, fn, persons in view)."""
    state = detector.state
    view = detector.in_view(frame)
    person = state.class_names.index("person")
    rows = [int(r) for r in view.rows if state.class_codes[r] == person]
    truth = {state.ids[r]: (float(state.positions[r, 0]), float(state.positions[r, 1])) for r in rows}
    tracks = {o.id: (o.pose.north, o.pose.east) for o in world.objects_of("person", states=("confirmed",))}
    matched = len(TrackingScore(max_distance_m=gate_m).add(truth, tracks))
    return matched, len(tracks) - matched, len(truth) - matched, len(truth)


def _record(run: _Run, common: dict[str, object]) -> DecisionRecord:
    decision = run.last
    assert decision is not None
    a = decision.assessment
    person = a is not None and a.persons_detected > 0
    return DecisionRecord.model_validate(
        {
            **common,
            "system": run.system.name,
            "processing_time_s": run.time_s / max(run.assessments, 1),
            "detection_confidence": a.confidence if a is not None and person else None,
            "person_detected": person,
            "n_actions": len(a.recommended_actions) if a is not None else 0,
            "action_recommended": a is not None and a.recommends_action,
            "contextual": a is not None and a.contextual,
            "error": decision.error,
            "severity": a.severity if a is not None else None,
            "persons_detected": a.persons_detected if a is not None else None,
            "subject_id": a.subject_id if a is not None else None,
            "assessment": a,
            "reasoner": decision.reasoner,
            "model_time_s": run.model_s / max(run.assessments, 1),
            "llm_calls": decision.llm_calls,
            "prompt_tokens": decision.prompt_tokens,
            "completion_tokens": decision.completion_tokens,
            "cached": decision.cached,
            "escalated": decision.escalated,
            "assessments": run.assessments,
            "episode_llm_calls": run.llm_calls,
            "episode_tokens": run.tokens,
            "episode_time_s": run.time_s,
            "episode_model_time_s": run.model_s,
            "sim_time_s": run.last_time_s,
            "time_to_intervention_s": run.intervention_s,
        }
    )


__all__ = ["DEFAULT_GOAL", "EpisodeSettings", "derive_seed", "perception_seed", "point_of_interest", "run_episode"]
