"""Missions (YAML text) and triggers the agent's tests compile or hand to the gate."""

from __future__ import annotations

from agentic_core.mission import PolicyGraph, load_mission
from agentic_core.mission.model import Trigger

WATCHED = """
plan_id: watched
goal: fly a leg and then go home, helping anyone found on the way
steps:
  - {id: up, action: takeoff, args: {altitude_m: 30}}
  - {id: leg, action: fly_to, depends_on: [up], args: {north_m: 100, east_m: 0, alt_m: 30}}
  - {id: home, action: rtl, depends_on: [leg]}
triggers:
  - id: fallen
    when: "find(world, class_='person', stationary_s__gte=5)"
    steps:
      - {id: warn, action: notify, args: {subject: "${event.id}", body: "someone is down"}}
"""

PATROL = """
plan_id: patrol
goal: two passes over two gates, helping anyone found on the way
steps:
  - {id: up, action: takeoff, args: {altitude_m: 30}}
  - id: patrol
    action: repeat
    depends_on: [up]
    until: "patrol.iterations >= 2"
    steps:
      - {id: gate_a, action: fly_to, args: {north_m: 100, east_m: 0, alt_m: 30}}
      - {id: gate_b, action: fly_to, args: {north_m: 0, east_m: 100, alt_m: 30}}
  - {id: home, action: rtl, depends_on: [patrol]}
triggers:
  - id: fallen
    when: "find(world, class_='person', stationary_s__gte=5)"
    steps:
      - {id: warn, action: notify, args: {subject: "${event.id}", body: "someone is down"}}
"""

SURVEY = """
plan_id: survey
goal: sweep a small square
steps:
  - id: sweep
    action: survey
    args:
      polygon: [{lat: 21.4130, lon: 39.8930}, {lat: 21.4130, lon: 39.8936}, {lat: 21.4136, lon: 39.8936},
                {lat: 21.4136, lon: 39.8930}]
      spacing_m: 20
      altitude_m: 30
"""

TWO_TRIGGERS = """
plan_id: triggers
goal: hold a trigger of each kind
steps:
  - {id: look, action: hover, args: {duration_s: 1}}
triggers:
  - id: fallen
    when: "find(world, class_='person')"
    steps: [{id: warn, action: notify, args: {subject: "${event.id}", body: "down"}}]
  - id: again
    when: "find(world, class_='person')"
    once: false
    preempt: false
    steps: [{id: note, action: notify, args: {subject: "${event.id}", body: "seen"}}]
"""


def mission(text: str) -> PolicyGraph:
    return load_mission(text, file="test.yaml")


def trigger(trigger_id: str = "fallen", text: str = TWO_TRIGGERS) -> Trigger:
    return next(t for t in mission(text).triggers if t.id == trigger_id)
