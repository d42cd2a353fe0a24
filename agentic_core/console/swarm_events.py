"""A swarm's records as timeline events the page shows beside its UAVs' own: each ``swarm.jsonl`` record (a Contract
Net round and its award, the sectors, a consensus, a claim, a verification, a delivery, a failure) and each refused
message of ``refusals.jsonl``, with a line of text, its simulated time and the UAV it is about.

>>> swarm_event({"event": "round", "sim_t": 0.0, "task": "survey:S1", "bids": {"uav-1": 3.0}, "awarded": "uav-1"})
{'kind': 'swarm', 'event': 'round', 'sim_t': 0.0, 'uav': 'uav-1', 'summary': 'award survey:S1 to uav-1 (1 bids)'}
"""

from __future__ import annotations

import bisect
from typing import Any


def _names(value: Any) -> str:
    if isinstance(value, dict):
        return ", ".join(f"{k} to {v}" for k, v in value.items()) or "nothing"
    if isinstance(value, list):
        return ", ".join(str(v) for v in value) or "nobody"
    return str(value)


def _summary(r: dict[str, Any]) -> str:
    event = r.get("event")
    if event == "round":
        bids = r.get("bids")
        bids = bids if isinstance(bids, dict) else {}
        silent = f", silent {_names(r.get('silent'))}" if r.get("silent") else ""
        return f"award {r.get('task')} to {r.get('awarded') or 'nobody'} ({len(bids)} bids{silent})"
    if event in ("sectors", "consensus"):
        return f"{event}: {_names(r.get('awarded'))}"
    if event == "claim":
        if r.get("claimed"):
            return f"claims {r.get('object')} as casualty {r.get('casualty')}"
        return f"{r.get('object')} already claimed by {r.get('by')}"
    if event == "verify":
        verdict = "verified" if r.get("verified") else "not yet verified"
        return f"casualty {r.get('casualty')} seen by {_names(r.get('seen_by'))} (k={r.get('k')}): {verdict}"
    if event == "delivered":
        return f"kit delivered to casualty {r.get('casualty')}"
    if event == "covered":
        return f"sector {r.get('sector')} surveyed ({r.get('surveys')})"
    if event == "failed":
        return f"failed: {r.get('why')}; tasks moved: {_names(r.get('moved'))}"
    if event == "clearance":
        verdict = "clear" if r.get("clear") else "blocked by " + _names(r.get("blocking"))
        return f"clearance for {r.get('task')}: {verdict}"
    shown = {k: v for k, v in r.items() if k not in ("event", "sim_t", "t")}
    return f"{event}: {shown}"[:300]


def swarm_event(record: dict[str, Any]) -> dict[str, Any]:
    """One ``swarm.jsonl`` record as a timeline event (kind ``swarm``), with the UAV it is about: the one that
    acted, or the one awarded."""
    awarded = record.get("awarded")
    uav = record.get("uav") or (awarded if isinstance(awarded, str) else None)
    sim_t = record.get("sim_t") if isinstance(record.get("sim_t"), (int, float)) else None
    return {"kind": "swarm", "event": str(record.get("event")), "sim_t": sim_t,
            "uav": str(uav) if uav else "swarm", "summary": _summary(record)}  # fmt: skip


def refusal_event(record: dict[str, Any], clock: list[tuple[float, float]]) -> dict[str, Any]:
    """One refused swarm message as a timeline event; its wall time (``at``) put on the simulated clock by the
    swarm's last record before it (``clock``: (wall, simulated) pairs, in order)."""
    at = record.get("at")
    sim_t = None
    if isinstance(at, (int, float)) and clock:
        i = bisect.bisect_right([wall for wall, _ in clock], float(at))
        sim_t = clock[max(0, i - 1)][1]
    summary = f"refused {record.get('kind') or 'message'} from {record.get('sender')!r}: {record.get('reason')}"
    detail = record.get("detail")
    return {"kind": "swarm", "event": "refused", "sim_t": sim_t, "uav": str(record.get("receiver") or "swarm"),
            "summary": summary + (f" ({detail})" if detail else "")}  # fmt: skip


__all__ = ["refusal_event", "swarm_event"]
