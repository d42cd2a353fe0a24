"""A stand-in model for whole runs, behind the OpenAI-compatible stand-in server: it reads each request as a model
would — the World Model in an assessment prompt, the event in a planning prompt — and answers in the structured
output asked for. No model is downloaded or called; what is tested is our side of the exchange."""

from __future__ import annotations

import json
import math
import re
import threading
from typing import Any

from ..reasoning.llm.standin import Reply, openai_completion

EMERGENCY_PLAN: list[dict[str, Any]] = [
    {"id": "go_to_casualty", "action": "fly_to", "args": {"target_id": "${event.id}", "alt_m": 15}},
    {"id": "watch", "action": "hover", "depends_on": ["go_to_casualty"], "args": {"duration_s": 10}},
    {"id": "recheck", "action": "analyze_scene", "depends_on": ["watch"], "args": {"focus": "${event.id}"}},
    {
        "id": "call_medics", "action": "notify", "depends_on": ["recheck"], "on_fail": "skip",
        "preconditions": ["recheck.assessment.severity == 'critical'"],
        "args": {
            "channel": "email", "to": "medical-team@example.org",
            "subject": "Casualty at ${event.pose.lat}, ${event.pose.lon}",
            "body": "${recheck.assessment.surrounding_features}", "attach": ["position", "snapshot", "assessment"],
        },
    },
    {
        "id": "land_beside", "action": "land", "depends_on": ["recheck"], "approval": True, "on_fail": "skip",
        "preconditions": ["recheck.assessment.severity == 'critical'"],
        "args": {"target_id": "${event.id}", "offset_m": 5},
    },
    {
        "id": "drop_kit", "action": "deploy_payload", "depends_on": ["land_beside"], "approval": True,
        "preconditions": ["land_beside.reached"], "args": {"payload": "rescue_kit"}, "on_fail": "skip",
    },
    {
        "id": "climb_out", "action": "takeoff", "depends_on": ["drop_kit"], "preconditions": ["land_beside.reached"],
        "args": {"altitude_m": 30}, "on_fail": "skip",
    },
    {"id": "return_home", "action": "rtl", "depends_on": ["climb_out"], "on_fail": "skip"},
]  # fmt: skip
"""The response a careful model writes for a collapsed pilgrim, in the mission language, with new step ids."""


class ScriptedModel:
    """Answers assessment requests from the World Model (a person isolated and motionless for ``still_s`` is
    critical, for less is worth a look) and planning requests with ``plan``; counts the requests of each kind."""

    def __init__(self, plan: list[dict[str, Any]] | None = None, *, still_s: float = 10.0) -> None:
        self.plan = EMERGENCY_PLAN if plan is None else plan
        self.still_s = still_s
        self.asked: dict[str, int] = {"Assessment": 0, "Proposal": 0}
        self.plan_prompts: list[str] = []
        self._lock = threading.Lock()

    def __call__(self, path: str, body: Any) -> Reply:
        kind = body["response_format"]["json_schema"]["name"]
        prompt = body["messages"][-1]["content"]
        with self._lock:
            self.asked[kind] = self.asked.get(kind, 0) + 1
        if kind == "Proposal":
            self.plan_prompts.append(prompt)
            return openai_completion(json.dumps({"steps": self.plan, "rationale": "approach, confirm, help"}))
        return openai_completion(json.dumps(self.assess(prompt)), prompt_tokens=900, completion_tokens=80)

    def assess(self, prompt: str) -> dict[str, Any]:
        world = json.loads(prompt.split("World Model (JSON):\n", 1)[1].split("\n\nGive:", 1)[0])
        focus = re.search(r"Focus on object (\S+)\.", prompt)
        people = [o for o in world["objects"] if o["class"] == "person"]
        isolated = {r["subj"] for r in world["relations"] if r["pred"] == "isolated_from"}
        subject = next((o for o in people if focus and o["id"] == focus.group(1)), None)
        severity, actions = "none", ["continue_patrol"]
        if subject is not None and self.sheltered(subject, world.get("landmarks") or []):
            severity, actions = "low", ["log_observation"]  # resting in the shade, not collapsed
        elif subject is not None and subject["id"] in isolated and subject["stationary_s"] >= self.still_s:
            severity, actions = "critical", ["land_nearby", "deploy_rescue_kit", "alert_medical_team"]
        elif subject is not None and subject["id"] in isolated and subject["stationary_s"] >= 2:
            severity, actions = "high", ["approach_and_confirm"]
        return {
            "persons_detected": len(people),
            "confidence": 0.88,
            "surrounding_features": "A pilgrim lying motionless on open ground, apart from the flow of the crowd."
            if severity in ("high", "critical")
            else "Pilgrims walking in a steady flow; no one in distress.",
            "severity": severity,
            "recommended_actions": actions,
            "rationale": f"{subject['id'] if subject else 'no one'} read from the World Model",
            "subject_id": subject["id"] if subject else None,
        }

    @staticmethod
    def sheltered(person: dict[str, Any], landmarks: list[dict[str, Any]]) -> bool:
        """Within 12 m of a tent, shade or medical post (or inside its radius)."""
        here = person["pose"]
        return any(
            math.hypot(lm["north"] - here["north"], lm["east"] - here["east"]) <= max(12.0, lm.get("radius_m") or 0.0)
            for lm in landmarks
            if lm.get("kind") in ("tent", "shade", "medical_post")
        )
