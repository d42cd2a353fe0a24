"""A run's :class:`~agentic_core.run.report.RunSummary` from what it recorded: its trace (decisions, model
exchanges, alerts sent), the alerts folder, the perception loop's counters and the scene's ground truth."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .report import RunSummary

if TYPE_CHECKING:
    from .runner import MissionRun


def summarise(run: MissionRun, outcome: str, wall_s: float) -> RunSummary:
    """The summary of ``run`` ending with ``outcome`` after ``wall_s`` seconds of wall time."""
    trace, loop, scene = run.trace, run.loop, run.scene
    decisions = trace.of_kind("decision")
    exchanges = trace.of_kind("plan") + trace.of_kind("reflection")  # one model call each
    alerts = sorted(str(p) for p in run.alerts_dir.glob("*") if p.is_file()) if run.alerts_dir.exists() else []
    sent = [r for r in trace.of_kind("tool") if r.get("name") == "alerts.notify" and r.get("status") == "ok"]
    casualties = scene.ground_truth.casualties if scene else []
    return RunSummary(
        run_id=run.run_id,
        mission=str(run.settings.mission),
        scene=scene.id if scene else None,
        reasoner=run.reasoner.name,
        outcome=outcome,
        sim_duration_s=run.clock(),
        wall_duration_s=wall_s,
        alerts=alerts,
        decisions=len(decisions),
        llm_calls=sum(int(d.get("llm_calls", 0)) for d in decisions) + len(exchanges),
        tokens=sum(int(d.get("prompt_tokens", 0)) + int(d.get("completion_tokens", 0)) for d in decisions)
        + sum(int(e.get("tokens", 0)) for e in exchanges),
        llm_calls_saved=getattr(run.reasoner, "saved", None),
        frames=loop.frames if loop else 0,
        perception_ms_per_frame=1000 * loop.busy_s / loop.frames if loop and loop.frames else None,
        casualties=list(casualties),
        first_detected_s={k: v for k, v in (loop.first_detected.items() if loop else []) if k in casualties},
        alert_sent_s=sent[0].get("sim_t") if sent else None,
        truth_ids=dict(run.links),
    )


__all__ = ["summarise"]
