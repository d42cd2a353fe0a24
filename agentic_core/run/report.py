"""A run's report: ``report.md`` with the outcome, the decisions, the alerts, a timeline, and ``trajectory.png``
(the flown track over the scene, with the people who needed help and where the aircraft landed).

Everything in it comes from the run's trace and its recorded track, so the report says what happened, not what
was meant to.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from matplotlib.figure import Figure
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
    outcome: str = Field(description="completed, aborted, returned (rtl), failed or interrupted")
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


def plot_trajectory(track: Sequence[TrackPoint], scene: Scene | None, path: Path, landed: TrackPoint | None) -> Path:
    """The flown track (north up), the scene's zones and landmarks, its casualties, home and the landing spot."""
    fig = Figure(figsize=(6.4, 6.4), dpi=110)
    ax = fig.add_subplot()
    if scene is not None:
        for zone in scene.zones:
            if zone.polygon:
                xs = [p.east for p in zone.polygon] + [zone.polygon[0].east]
                ys = [p.north for p in zone.polygon] + [zone.polygon[0].north]
                ax.fill(xs, ys, color="#f3e3b5", alpha=0.5, linewidth=0)
        for landmark in scene.landmarks:
            position = landmark.position or (landmark.polygon[0] if landmark.polygon else None)
            if position is not None:
                ax.plot(position.east, position.north, "s", color="#7a7a7a", markersize=5)
                ax.annotate(landmark.name or landmark.id, (position.east, position.north), fontsize=7, color="#555")
        for actor_id in scene.ground_truth.casualties:
            actor = scene.actor(actor_id)
            ax.plot(actor.position.east, actor.position.north, "X", color="#d62728", markersize=10, label=actor_id)
    if track:
        ax.plot([p.east_m for p in track], [p.north_m for p in track], color="#1f77b4", linewidth=1.5, label="flown")
        ax.plot(0.0, 0.0, "^", color="black", markersize=8, label="home")
    if landed is not None:
        ax.plot(landed.east_m, landed.north_m, "o", color="#2ca02c", markersize=8, label="landed")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    ax.set_title("Trajectory", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, format="png", metadata={"Software": None})
    return path


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


def write_report(
    run_dir: Path,
    summary: RunSummary,
    records: Sequence[dict[str, Any]],
    track: Sequence[TrackPoint],
    scene: Scene | None,
) -> Path:
    """Write ``report.md`` and ``trajectory.png`` into ``run_dir``; return the report's path."""
    landed = landing_spot(track)
    links = summary.truth_ids
    plot_trajectory(track, scene, run_dir / "trajectory.png", landed)
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
    lines += ["", "![trajectory](trajectory.png)", "", "## Decisions", ""]
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
    if summary.notes:
        lines += ["", "## Notes", "", *[f"- {readable(note, links)}" for note in summary.notes]]
    lines += ["", "## Timeline", "", "| sim time (s) | event |", "|---:|---|"]
    lines += [f"| {t:.1f} | {readable(what, links).replace('|', '/')} |" for t, what in timeline(records)]
    path = run_dir / "report.md"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


__all__ = ["RunSummary", "TrackPoint", "landing_spot", "plot_trajectory", "timeline", "write_report"]
