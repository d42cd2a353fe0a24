"""``trajectory.png``: the flown track from above (north up), coloured by altitude, over the scene's crowd zones and
landmarks, with home, start, end, the time every so often along the way, the casualties and where the aircraft
landed away from home.

Why: one picture should say where the aircraft went, how high, when, and past which crowds. The view is the flight
(and the casualties), not the whole scene, so a short flight is not a speck; labels never sit on each other
(:mod:`.labels`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Polygon

from flight.sim.scene_model import Scene, Zone

from .labels import LabelPlacer

if TYPE_CHECKING:
    from ..report import TrackPoint

ZONE_COLOURS = {"walkway": "#e9c46a", "plaza": "#f4a261", "camp": "#8ab17d", "queue": "#b392ac"}
TIME_STEPS_S = (5, 10, 15, 30, 60, 120, 300, 600, 900, 1800)
MIN_SPAN_M = 60.0
HOME_RADIUS_M = 3.0
"""A start or an end this close to home is said to be at home (and no separate home marker is drawn)."""


def time_marks(track: Sequence[TrackPoint], most: int = 8) -> list[TrackPoint]:
    """The points of ``track`` at round times (every 10 s, 30 s, 1 min… so that at most ``most`` fit), the
    first and last left out (start and end have markers of their own).

    >>> from agentic_core.run.report import TrackPoint
    >>> track = [TrackPoint(sim_t=t / 10, north_m=0, east_m=0, alt_m=0) for t in range(0, 1301)]
    >>> [p.sim_t for p in time_marks(track)]
    [30.0, 60.0, 90.0, 120.0]
    """
    if len(track) < 2:
        return []
    t0, t1 = track[0].sim_t, track[-1].sim_t
    step = next((s for s in TIME_STEPS_S if (t1 - t0) / s <= most), TIME_STEPS_S[-1])
    times = np.array([p.sim_t for p in track])
    marks = []
    for mark in np.arange((t0 // step + 1) * step, t1, step):
        i = int(np.searchsorted(times, mark))
        if 0 < i < len(track) - 1:
            marks.append(track[i])
    return marks


def view(track: Sequence[TrackPoint], scene: Scene | None) -> tuple[tuple[float, float], tuple[float, float]]:
    """(east range, north range) that holds home, the track and the casualties, with a margin."""
    easts, norths = [0.0], [0.0]
    easts += [p.east_m for p in track]
    norths += [p.north_m for p in track]
    if scene is not None:
        for actor_id in scene.ground_truth.casualties:
            position = scene.actor(actor_id).position
            easts.append(position.east)
            norths.append(position.north)
    span = max(max(easts) - min(easts), max(norths) - min(norths), MIN_SPAN_M)
    pad = 0.12 * span
    mid_e, mid_n = (max(easts) + min(easts)) / 2, (max(norths) + min(norths)) / 2
    half = span / 2 + pad
    return (mid_e - half, mid_e + half), (mid_n - half, mid_n + half)


def _at_home(point: TrackPoint) -> bool:
    return bool(abs(point.north_m) < HOME_RADIUS_M and abs(point.east_m) < HOME_RADIUS_M)


def _zone_anchor(zone: Zone, east: tuple[float, float], north: tuple[float, float]) -> tuple[float, float] | None:
    """Where to name a zone: its centre, moved into the view along the zone's own extent; None if out of view."""
    if zone.circle is not None:
        points = [(zone.circle.center.east, zone.circle.center.north)]
    else:
        points = [(p.east, p.north) for p in zone.polygon or []]
    if not points:
        return None
    es, ns = [p[0] for p in points], [p[1] for p in points]
    lo_e, hi_e = max(min(es), east[0]), min(max(es), east[1])
    lo_n, hi_n = max(min(ns), north[0]), min(max(ns), north[1])
    if lo_e > hi_e or lo_n > hi_n:
        return None
    return (lo_e + hi_e) / 2, (lo_n + hi_n) / 2


def _draw_zones(ax: object, scene: Scene, east: tuple[float, float], north: tuple[float, float]) -> list[str]:
    """The crowd zones, filled by kind; the kinds in view."""
    kinds: list[str] = []
    for zone in scene.zones:
        if _zone_anchor(zone, east, north) is None:
            continue
        colour = ZONE_COLOURS.get(zone.kind, "#cccccc")
        if zone.polygon:
            patch: Polygon | Circle = Polygon([(p.east, p.north) for p in zone.polygon], closed=True)
        elif zone.circle is not None:
            patch = Circle((zone.circle.center.east, zone.circle.center.north), zone.circle.radius_m)
        else:
            continue
        patch.set(facecolor=colour, edgecolor=colour, alpha=0.35, linewidth=1.0, zorder=1)
        ax.add_patch(patch)  # type: ignore[attr-defined]
        if zone.kind not in kinds:
            kinds.append(zone.kind)
    return kinds


def plot_trajectory(
    track: Sequence[TrackPoint], scene: Scene | None, path: Path, landed: TrackPoint | None = None
) -> Path:
    """Draw the flight over the scene into ``path`` (PNG) and return ``path``."""
    fig, _ = draw_trajectory(track, scene, landed)
    fig.savefig(path, format="png", metadata={"Software": None})
    return path


def draw_trajectory(
    track: Sequence[TrackPoint], scene: Scene | None, landed: TrackPoint | None = None
) -> tuple[Figure, LabelPlacer]:
    """The figure of :func:`plot_trajectory`, and the placer that put its labels (to check them)."""
    fig = Figure(figsize=(7.0, 7.0), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    east, north = view(track, scene)
    ax.set_xlim(*east)
    ax.set_ylim(*north)
    ax.set_aspect("equal", adjustable="box")
    ax.grid(alpha=0.25, zorder=0)
    ax.set_xlabel("east of home (m)")
    ax.set_ylabel("north of home (m)")
    handles: list[Patch | Line2D] = []
    kinds = _draw_zones(ax, scene, east, north) if scene is not None else []
    handles += [Patch(facecolor=ZONE_COLOURS.get(k, "#cccccc"), alpha=0.35, label=f"crowd: {k}") for k in kinds]
    if len(track) >= 2:
        xy = np.array([(p.east_m, p.north_m) for p in track])
        alt = np.array([p.alt_m for p in track])
        lines = LineCollection(list(np.stack([xy[:-1], xy[1:]], axis=1)), cmap="viridis", linewidth=2.2, zorder=3)
        lines.set_array((alt[:-1] + alt[1:]) / 2)
        ax.add_collection(lines)
        fig.colorbar(lines, ax=ax, shrink=0.75, pad=0.02, label="altitude above home (m)")
    marks = time_marks(track)
    if marks:
        ax.plot([p.east_m for p in marks], [p.north_m for p in marks], "o", color="white", markeredgecolor="#333",
                markersize=4, zorder=4)  # fmt: skip
    points: list[tuple[float, float, str, dict[str, object]]] = []
    if scene is not None:
        for landmark in scene.landmarks:
            at = landmark.center
            if east[0] <= at.east <= east[1] and north[0] <= at.north <= north[1]:
                ax.plot(at.east, at.north, "s", color="#6c757d", markersize=4, zorder=2)
                points.append((at.east, at.north, landmark.name or landmark.id, {"fontsize": 7, "color": "#495057"}))
        for actor_id in scene.ground_truth.casualties:
            at = scene.actor(actor_id).position
            ax.plot(at.east, at.north, "X", color="#d62828", markersize=11, markeredgecolor="white", zorder=6)
        if scene.ground_truth.casualties:
            handles.append(Line2D([], [], marker="X", color="#d62828", linestyle="", markersize=9, label="casualty"))
    ends: list[tuple[TrackPoint, str, str, str]] = []
    if track:
        ends += [(track[0], "o", "#2a9d8f", "start"), (track[-1], "s", "#e76f51", "end")]
    if landed is not None:
        ends.append((landed, "v", "#264653", "landed"))
    if not any(_at_home(p) for p, *_ in ends):
        ax.plot(0.0, 0.0, "H", color="black", markersize=10, zorder=5)
        handles.append(Line2D([], [], marker="H", color="black", linestyle="", markersize=8, label="home"))
    for point, marker, colour, name in ends:
        ax.plot(point.east_m, point.north_m, marker, color=colour, markersize=9, markeredgecolor="white", zorder=7)
        handles.append(Line2D([], [], marker=marker, color=colour, linestyle="", markersize=8, label=name))
    ax.set_title(f"Trajectory ({track[-1].sim_t - track[0].sim_t:.0f} s flown)" if track else "Trajectory: no track")
    fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 5), fontsize=8, frameon=False)
    fig.canvas.draw()  # the layout and the aspect are final from here: the labels measure where they will be
    fig.set_layout_engine("none")
    placer = LabelPlacer(ax)
    placer.avoid_markers([(p.east_m, p.north_m) for p, *_ in ends] + [(0.0, 0.0)])
    placer.avoid_markers([(x, y) for x, y, *_ in points] + [(p.east_m, p.north_m) for p in marks])
    if scene is not None:
        casualties = [scene.actor(a).position for a in scene.ground_truth.casualties]
        placer.avoid_markers([(at.east, at.north) for at in casualties])
    placer.avoid_track([(p.east_m, p.north_m) for p in track[:: max(1, len(track) // 400)]])
    bold = {"fontsize": 8, "fontweight": "bold"}
    if scene is not None:
        for actor_id in scene.ground_truth.casualties:
            at = scene.actor(actor_id).position
            placer.place(at.east, at.north, actor_id, must=True, color="#d62828", **bold)
    for point, _, colour, name in ends:
        where = " at home" if _at_home(point) else ""
        placer.place(point.east_m, point.north_m, f"{name}{where} {point.sim_t:.0f} s", must=True, color=colour, **bold)
    for x, y, text, style in points:
        placer.place(x, y, text, **style)  # type: ignore[arg-type]
    if scene is not None:
        for zone in scene.zones:
            anchor = _zone_anchor(zone, east, north)
            if anchor is not None:
                placer.place(*anchor, zone.name or zone.id, fontsize=7, fontstyle="italic", color="#6b5b2a")
    for mark in marks:
        placer.place(mark.east_m, mark.north_m, f"{mark.sim_t:.0f} s", fontsize=7, color="#333")
    return fig, placer


__all__ = ["draw_trajectory", "plot_trajectory", "time_marks", "view"]
