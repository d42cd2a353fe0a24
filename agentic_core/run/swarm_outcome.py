"""What a swarm run achieved, honestly: every sector covered, every casualty of the scene found, verified, alerted
and served, the separation kept, every UAV's own outcome — and the exit status that says so (0 all of it; 3 all of
it but a UAV was lost or an alert reached only the outbox; 1 anything short of it). Written as ``summary.json`` and
``report.md`` in the swarm's directory.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

from .responses import DEGRADED_EXIT

GOOD = ("completed", "returned")


def _alerted(result: Any, after_s: float | None) -> bool:
    """Whether the run sent an alert (``alerts.notify`` ok) at or after ``after_s`` of simulated time."""
    if result is None:
        return False
    trace = result.run_dir / "trace.jsonl"
    for line in trace.read_text(encoding="utf-8").splitlines() if trace.exists() else []:
        record = json.loads(line)
        sent = record.get("kind") == "tool" and record.get("name") == "alerts.notify" and record.get("status") == "ok"
        if (
            sent
            and (record.get("args") or {}).get("channel") != "log"
            and (after_s is None or record.get("sim_t", 0) >= after_s)
        ):
            return True
    return False


def _claimed_at(swarm: Any, casualty: str) -> float | None:
    path = swarm.dir / "swarm.jsonl"
    for line in path.read_text(encoding="utf-8").splitlines() if path.exists() else []:
        record = json.loads(line)
        if record.get("event") == "claim" and record.get("casualty") == casualty and record.get("claimed"):
            return float(record.get("sim_t", 0.0))
    return None


def outcome_of(swarm: Any, wall_s: float) -> dict[str, Any]:
    """The summary of a finished :class:`~agentic_core.run.swarm_run.SwarmRun`."""
    coordinator = swarm.coordinator
    seats = {s.uav: s for s in swarm.seats}
    uavs = {
        uav: {
            "outcome": s.result.summary.outcome if s.result else "crashed",
            "error": s.error,
            "run_dir": str(s.result.run_dir if s.result else (s.run.run_dir if s.run else "")),
            "role": swarm.plan_swarm.role_of(s.index),
            "system_id": s.system_id,
            "sim_s": round(s.result.summary.sim_duration_s, 1) if s.result else None,
        }
        for uav, s in seats.items()
    }
    coverage = {sector: list(by) for sector, by in coordinator.coverage.items()}
    truth_found: dict[str, str] = {}
    casualties = []
    for c in coordinator.casualties.values():
        finder = seats[c.finder]
        truth = finder.result.summary.truth_ids.get(c.object_id) if finder.result else None
        if truth:
            truth_found[truth] = c.id
        verified = c.verified
        alerted = _alerted(finder.result, _claimed_at(swarm, c.id))
        casualties.append({
            "id": c.id, "found_by": c.finder, "object": c.object_id, "truth": truth, "verified_by": c.verified_by,
            "verified": verified, "alerted": alerted, "delivery_awarded": c.delivery, "delivered": c.delivered,
        })  # fmt: skip
    scene_casualties = list(swarm.seats[0].run.scene.ground_truth.casualties) if swarm.seats[0].run.scene else []
    separation = swarm.separation.report()
    refusals = Counter(r.reason for r in swarm.audit.memory.rejections)
    problems = [f"sector {s} surveyed {len(by)} of {coordinator.rounds} times" for s, by in coverage.items()
                if len(by) < coordinator.rounds]  # fmt: skip
    problems += [f"casualty {t} never found" for t in scene_casualties if t not in truth_found]
    for c in casualties:
        problems += [f"{c['id']} not {what}" for what in ("verified", "alerted", "delivered") if not c[what]]
    if separation["losses"]:
        problems.append(
            f"separation lost at {separation['losses']} instants (closest {separation['min_distance_m']} m)"
        )
    lost = sorted(coordinator.failed)
    degraded = [u for u, v in uavs.items() if v["outcome"] == "degraded"]
    if problems:
        outcome, code = "failed", 1
    elif lost or degraded:
        outcome, code = "degraded", DEGRADED_EXIT
    else:
        outcome, code = "completed", 0
    return {
        "swarm_id": swarm.swarm_id, "mission": str(swarm.settings.mission), "vehicles": swarm.n,
        "outcome": outcome, "exit": code, "problems": problems, "lost": lost, "uavs": uavs,
        "sectors": coverage, "casualties": casualties, "scene_casualties": scene_casualties,
        "separation": separation, "refusals": dict(refusals), "rounds": coordinator.rounds,
        "verify_k": coordinator.verify_k,
        "verify_by": coordinator.verification.by, "sim_s": round(swarm.time_s(), 1), "wall_s": round(wall_s, 1),
        "allocation": dict(coordinator.manager.allocation.awarded), "a2a": coordinator.a2a_report(),
        "ground_link_lost_s": coordinator.ground_lost_at, "airspace": dict(coordinator.legs.counts),
    }  # fmt: skip


def write_summary(directory: Path, summary: dict[str, Any]) -> None:
    """``summary.json`` and a short ``report.md`` in ``directory``."""
    (directory / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n", encoding="utf-8")
    sep = summary["separation"]
    lines = [
        f"# Swarm run {summary['swarm_id']}",
        "",
        f"Outcome: **{summary['outcome']}** (exit {summary['exit']}); {summary['vehicles']} UAVs, "
        f"{summary['sim_s']} s simulated in {summary['wall_s']} s.",
        "",
        *(f"- problem: {p}" for p in summary["problems"]),
        *(f"- lost: {u} (its tasks auctioned again)" for u in summary["lost"]),
        *(f"- degraded: {u}'s run (an alert reached only the outbox: its report.md says which)"
          for u, v in summary["uavs"].items() if v["outcome"] == "degraded"),
        "",
        "| UAV | system id | role | outcome | run |",
        "|---|---|---|---|---|",
        *(f"| {u} | {v['system_id']} | {v['role'] or ''} | {v['outcome']} | {v['run_dir']} |"
          for u, v in summary["uavs"].items()),
        "",
        "Sectors (surveyed by): "
        + "; ".join(f"{s}: {', '.join(by) or 'nobody'}" for s, by in summary["sectors"].items()),
        "",
        *(f"Casualty {c['id']} ({c['truth'] or c['object']}): found by {c['found_by']}, seen by "
          f"{', '.join(c['verified_by']) or 'nobody else'}, verified {c['verified']}, alerted {c['alerted']}, "
          f"kit awarded to {c['delivery_awarded']}, delivered {c['delivered']}." for c in summary["casualties"]),
        "",
        f"Separation: closest {sep['min_distance_m']} m ({', '.join(sep['closest'])} at {sep['at_s']} s); "
        f"minimum {sep['horizontal_m']} m horizontal or {sep['vertical_m']} m vertical; losses: {sep['losses']}.",
        *([f"Legs reserved before they were flown (swarm.jsonl's leg events): {summary['airspace']}."]
          if "airspace" in summary else []),
        f"Refused swarm messages: {summary['refusals'] or 'none'}.",
        *([f"Ground link lost at {summary['ground_link_lost_s']} s: from then on the UAVs allocated among themselves "
           "by consensus (swarm.jsonl's consensus events)."] if summary.get("ground_link_lost_s") is not None else []),
    ]  # fmt: skip
    (directory / "report.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


__all__ = ["outcome_of", "write_summary"]
