"""One UAV's share of a swarm mission: the steps and triggers it has, as a mission of its own for its agent loop.
A step or trigger without ``uav:`` is every UAV's, one naming ``any`` too (the swarm decides at run time which UAV
acts on it), one naming a role only its holders'. A dropped step leaves the ``depends_on`` lists it was in. The
UAV's own values are set as its parameters' defaults (its altitude layer, its id, its role).

>>> mission = {"plan_id": "p", "goal": "g", "params": {}, "steps": [
...     {"id": "up", "action": "takeoff"},
...     {"id": "kit", "action": "deploy_payload", "uav": "medic", "depends_on": ["up"]},
...     {"id": "home", "action": "rtl", "depends_on": ["kit"]}]}
>>> [s["id"] for s in project(mission, role=None, params={})["steps"]]
['up', 'home']
>>> project(mission, role=None, params={})["steps"][1]["depends_on"]
[]
>>> [s["id"] for s in project(mission, role="medic", params={"layer_m": 40.0})["steps"]]
['up', 'kit', 'home']
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from agentic_core.contracts.swarm_plan import ANY

NESTED = ("steps", "then", "else")


def _kept(item: Mapping[str, Any], role: str | None) -> bool:
    uav = item.get("uav")
    return uav is None or uav in (ANY, role)


def _filter(steps: list[Any], role: str | None, dropped: set[str]) -> list[Any]:
    kept = []
    for step in steps:
        if not isinstance(step, dict):
            kept.append(step)
            continue
        if not _kept(step, role):
            dropped.add(str(step.get("id")))
            continue
        for nested in NESTED:
            if isinstance(step.get(nested), list):
                step[nested] = _filter(step[nested], role, dropped)
        kept.append(step)
    return kept


def _prune(steps: list[Any], dropped: set[str]) -> None:
    for step in steps:
        if isinstance(step, dict):
            if isinstance(step.get("depends_on"), list):
                step["depends_on"] = [d for d in step["depends_on"] if d not in dropped]
            for nested in NESTED:
                if isinstance(step.get(nested), list):
                    _prune(step[nested], dropped)


def project(mission: Mapping[str, Any], *, role: str | None, params: Mapping[str, Any]) -> dict[str, Any]:
    """The mission (as parsed YAML) one UAV of ``role`` flies, its ``params`` set as defaults."""
    out = copy.deepcopy(dict(mission))
    dropped: set[str] = set()
    out["steps"] = _filter(list(out.get("steps") or []), role, dropped)
    out["triggers"] = [t for t in out.get("triggers") or [] if not isinstance(t, dict) or _kept(t, role)]
    for trigger in out["triggers"]:
        if isinstance(trigger, dict):
            trigger["steps"] = _filter(list(trigger.get("steps") or []), role, dropped)
    _prune(out["steps"], dropped)
    for trigger in out["triggers"]:
        if isinstance(trigger, dict):
            _prune(trigger["steps"], dropped)
    if isinstance(out.get("dependencies"), dict):
        out["dependencies"] = {
            k: [d for d in v if d not in dropped] for k, v in out["dependencies"].items() if k not in dropped
        }
    declared = out.setdefault("params", {})
    for name, value in params.items():
        if name in declared:
            declared[name] = {**declared[name], "default": value}
    return out


__all__ = ["project"]
