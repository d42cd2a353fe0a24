"""A run's report: ``report.md`` with the outcome, the decisions, the alerts, the failsafes and faults, a timeline,
``trajectory.png`` (the flown track over the scene, with the people who needed help and where the aircraft landed)
and ``flight.png`` (altitude, speed and battery over time, with the modes, decisions and failsafes), drawn by
:mod:`.plots`.

Everything in it comes from the run's trace and its recorded track, so the report says what happened, not what
was meant to.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from flight.sim.scene_model import Scene

from .readable import label, readable

TIMELINE_KINDS = ("run", "step", "trigger", "decision", "plan", "approval", "alert", "reflection", "refusal", "abort")


class TrackPoint(BaseModel):
    """One sample of the aircraft's true position (local metres from home; altitude above home)."""

    model_config = ConfigDict(frozen=True)

    sim_t: float
    north_m: float
    east_m: float
    alt_m: float
    armed: bool = True


class RunSummary(BaseModel):
    """The headline numbers of one run."""

    model_config = ConfigDict(extra="forbid")

    run_id: str
    mission: str
    scene: str | None
    reasoner: str
    outcome: str = Field(
        description="completed, returned (rtl), landed, held, degraded, aborted, failed, interrupted or lost"
    )
    sim_duration_s: float
    wall_duration_s: float
    alerts: list[str] = Field(default_factory=list, description="files of the alerts sent or kept in the outbox")
    decisions: int = 0
    llm_calls: int = 0
    tokens: int = 0
    llm_calls_saved: int | None = Field(
        default=None, description="hybrid: assessments answered without the model, each a call in the llm design"
    )
    frames: int = 0
    perception_ms_per_frame: float | None = None
    casualties: list[str] = Field(default_factory=list, description="the scene's ground truth")
    first_detected_s: dict[str, float] = Field(default_factory=dict)
    alert_sent_s: float | None = None
    notes: list[str] = Field(default_factory=list)
    truth_ids: dict[str, str] = Field(default_factory=dict, description="tracker id -> the scene's actor id")


def landing_spot(track: Sequence[TrackPoint]) -> TrackPoint | None:
    """Where the aircraft first touched down away from home (below 0.5 m, more than 5 m out), if it did."""
    for point in track:
        if point.alt_m < 0.5 and (point.north_m**2 + point.east_m**2) ** 0.5 > 5.0 and point.sim_t > 1.0:
            return point
    return None


def timeline(records: Sequence[dict[str, Any]]) -> list[tuple[float, str]]:
    """(simulated time, what happened) for the trace records a reader cares about."""
    rows = []
    for r in records:
        if r.get("kind") not in TIMELINE_KINDS:
            continue
        what = r.get("summary") or ", ".join(f"{k}={v}" for k, v in r.items() if k not in ("t", "sim_t", "kind"))
        rows.append((float(r.get("sim_t", 0.0)), f"{r['kind']}: {what}"))
    return rows


def failsafe_lines(records: Sequence[dict[str, Any]]) -> list[str]:
    """The failsafes that fired (the agent's on telemetry, the vehicle's own from its messages) and the faults
    injected, each with its simulated time and reason, in order."""
    lines = []
    for r in records:
        if r.get("kind") == "failsafe":
            who = "the vehicle" if r.get("by") == "vehicle" else f"the agent ({r.get('failsafe')})"
        elif r.get("kind") == "fault":
            who = "fault schedule"
        else:
            continue
        lines.append(f"- {float(r.get('sim_t') or 0.0):.1f} s, {who}: {r.get('summary')}")
    return lines or ["None."]


def write_report(
    run_dir: Path,
    summary: RunSummary,
    records: Sequence[dict[str, Any]],
    track: Sequence[TrackPoint],
    scene: Scene | None,
) -> Path:
    """Write ``report.md``, ``trajectory.png`` and ``flight.png`` into ``run_dir``; return the report's path.

    Matplotlib is imported here, at the end of a run, not when the run starts: a process that never reports (killed,
    or only validating) does not pay for it."""
    from .plots.flight import plot_flight, read_samples
    from .plots.trajectory import plot_trajectory

    landed = landing_spot(track)
    links = summary.truth_ids
    plot_trajectory(track, scene, run_dir / "trajectory.png", landed)
    plot_flight(read_samples(run_dir / "telemetry.jsonl"), records, run_dir / "flight.png")
    lines = [
        f"# Run {summary.run_id}",
        "",
        f"- Mission: `{summary.mission}`" + (f" over scene `{summary.scene}`" if summary.scene else ""),
        f"- Reasoner: `{summary.reasoner}`",
        f"- Outcome: **{summary.outcome}**",
        f"- Duration: {summary.sim_duration_s:.1f} s simulated in {summary.wall_duration_s:.1f} s",
        f"- Decisions: {summary.decisions}; model calls: {summary.llm_calls} ({summary.tokens} tokens)"
        + (f"; {summary.llm_calls_saved} saved by the hybrid design" if summary.llm_calls_saved is not None else ""),
    ]
    if summary.frames:
        per_frame = f", {summary.perception_ms_per_frame:.2f} ms each" if summary.perception_ms_per_frame else ""
        lines.append(f"- Perception: {summary.frames} camera frames{per_frame}")
    for casualty in summary.casualties:
        seen = summary.first_detected_s.get(casualty)
        seen_text = f"first detected at {seen:.1f} s" if seen is not None else "never detected"
        alert = (
            f"; alert sent at {summary.alert_sent_s:.1f} s ({summary.alert_sent_s - seen:.1f} s later)"
            if seen is not None and summary.alert_sent_s is not None
            else ""
        )
        tracks = [label(track, links) for track, truth in links.items() if truth == casualty]
        named = ", ".join(tracks) if tracks else f"{casualty} (scene; never tracked)"
        lines.append(f"- Casualty {named}: {seen_text}{alert}")
    if landed is not None:
        lines.append(f"- Landed away from home at north {landed.north_m:.1f} m, east {landed.east_m:.1f} m")
    lines += ["", "![trajectory](trajectory.png)", "", "![flight over time](flight.png)", "", "## Decisions", ""]
    decisions = [r for r in records if r.get("kind") == "decision"]
    if not decisions:
        lines.append("None.")
    for d in decisions:
        a = d.get("assessment") or {}
        subject = f" on {label(a['subject_id'], links)}" if a.get("subject_id") else ""
        confidence = f"{a['confidence']:.2f}" if isinstance(a.get("confidence"), float) else "-"
        lines.append(
            f"- {d.get('sim_t', 0):.1f} s, `{d.get('reasoner')}`{subject}: severity **{a.get('severity', '-')}**, "
            f"{a.get('persons_detected', '-')} persons, confidence {confidence}, actions "
            f"{', '.join(a.get('recommended_actions', [])) or 'none'}"
            + (f" — error: {d['error']}" if d.get("error") else "")
        )
        if a.get("surrounding_features"):
            lines.append(f"  - {readable(a['surrounding_features'], links)}")
    lines += ["", "## Alerts", ""]
    lines += [f"- `{path}`" for path in summary.alerts] or ["None."]
    lines += ["", "## Failsafes", "", *failsafe_lines(records)]
    if summary.notes:
        lines += ["", "## Notes", "", *[f"- {readable(note, links)}" for note in summary.notes]]
    lines += ["", "## Timeline", "", "| sim time (s) | event |", "|---:|---|"]
    lines += [f"| {t:.1f} | {readable(what, links).replace('|', '/')} |" for t, what in timeline(records)]
    path = run_dir / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


__all__ = ["RunSummary", "TrackPoint", "failsafe_lines", "landing_spot", "timeline", "write_report"]
