"""``flight.png``: altitude, ground speed and battery over the vehicle's time, from ``telemetry.jsonl``, on bands
that show the flight mode, with the reasoner's decisions (by severity) and the failsafes and operator stops marked.

Why: the trajectory says where; this says when, and why the aircraft changed what it was doing: a decision just
before a landing, a failsafe just before a return.

>>> import tempfile
>>> from agentic_core.contracts import TelemetrySample
>>> base = dict(lat_deg=21.4, lon_deg=39.9, north_m=0, east_m=0, down_m=-10, armed=True, battery_pct=90.0)
>>> samples = [TelemetrySample(time_s=t, alt_m=t, mode="takeoff" if t < 5 else "hold", **base) for t in range(10)]
>>> decision = {"kind": "decision", "sim_t": 6.0, "assessment": {"severity": "high"}}
>>> path = plot_flight(samples, [decision], Path(tempfile.mkdtemp()) / "flight.png")
>>> path.read_bytes()[:4], mode_spans(samples)
(b'\\x89PNG', [(0.0, 5.0, 'takeoff'), (5.0, 9.0, 'hold')])
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from pydantic import ValidationError

from ...contracts import TelemetrySample

MODE_COLOURS = {
    "hold": "#adb5bd", "takeoff": "#8ecae6", "land": "#ffb703", "rtl": "#fb8500", "offboard": "#90be6d",
    "mission": "#b5a6e8", "position": "#f4acb7",
}  # fmt: skip
SEVERITY_COLOURS = {"none": "#6c757d", "low": "#e9c46a", "high": "#f77f00", "critical": "#d62828"}
STOP_COLOUR = "#7b2cbf"


def read_samples(path: Path) -> list[TelemetrySample]:
    """The samples of a ``telemetry.jsonl`` (none if it is missing), skipping a line a kill cut short."""
    if not path.is_file():
        return []
    out = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            out.append(TelemetrySample.model_validate(json.loads(line)))
        except (json.JSONDecodeError, ValidationError):
            continue
    return out


def mode_spans(samples: Sequence[TelemetrySample]) -> list[tuple[float, float, str]]:
    """(from, to, mode) for each stretch of one flight mode, in the samples' order."""
    spans: list[tuple[float, float, str]] = []
    for sample in samples:
        if spans and spans[-1][2] == sample.mode:
            spans[-1] = (spans[-1][0], sample.time_s, sample.mode)
        else:
            if spans:  # the last stretch lasts until this one starts
                spans[-1] = (spans[-1][0], sample.time_s, spans[-1][2])
            spans.append((sample.time_s, sample.time_s, sample.mode))
    return spans


def _marks(records: Sequence[dict[str, Any]]) -> tuple[list[tuple[float, str]], list[tuple[float, str]]]:
    """(decisions as (time, severity), stops as (time, what)) from the trace."""
    decisions, stops = [], []
    for r in records:
        t = r.get("sim_t")
        if t is None:
            continue
        if r.get("kind") == "decision":
            severity = (r.get("assessment") or {}).get("severity") or ("error" if r.get("error") else "none")
            decisions.append((float(t), str(severity)))
        elif r.get("kind") == "failsafe":
            stops.append((float(t), f"failsafe: {r.get('failsafe', '?')} → {r.get('action', '?')}"))
        elif r.get("kind") == "control" and r.get("command") in ("abort", "rtl", "land"):
            stops.append((float(t), f"{r.get('command')} by {r.get('by', '?')}"))
    return decisions, stops


def _series(ax: Axes, times: list[float], values: list[float | None], label: str, colour: str) -> None:
    ax.plot(times, [math.nan if v is None else v for v in values], color=colour, linewidth=1.4, zorder=3)
    ax.set_ylabel(label, fontsize=9)
    ax.grid(alpha=0.25, zorder=0)
    ax.tick_params(labelsize=8)


def plot_flight(samples: Sequence[TelemetrySample], records: Sequence[dict[str, Any]], path: Path) -> Path:
    """Draw the flight over time into ``path`` (PNG) and return ``path``; a run without telemetry gets a figure
    that says so."""
    draw_flight(samples, records).savefig(path, format="png", metadata={"Software": None})
    return path


def draw_flight(samples: Sequence[TelemetrySample], records: Sequence[dict[str, Any]]) -> Figure:
    """The figure of :func:`plot_flight`."""
    fig = Figure(figsize=(8.0, 6.6), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1, sharex=True)
    if not samples:
        axes[0].set_title("Flight over time: no telemetry was recorded", fontsize=10)
        return fig
    times = [s.time_s for s in samples]
    _series(axes[0], times, [s.alt_m for s in samples], "altitude (m)", "#1d3557")
    _series(axes[1], times, [math.hypot(s.vn_mps, s.ve_mps) for s in samples], "ground speed (m/s)", "#2a9d8f")
    _series(axes[2], times, [s.battery_pct for s in samples], "battery (%)", "#e76f51")
    axes[2].set_xlabel("vehicle time (s)", fontsize=9)
    axes[2].set_xlim(times[0], max(times[-1], times[0] + 1.0))
    spans = mode_spans(samples)
    for start, end, mode in spans:
        for ax in axes:
            ax.axvspan(start, end, color=MODE_COLOURS.get(mode, "#dee2e6"), alpha=0.28, linewidth=0, zorder=1)
    decisions, stops = _marks(records)
    top = axes[0]
    for t, severity in decisions:
        colour = SEVERITY_COLOURS.get(severity, "#343a40")
        for ax in axes:
            ax.axvline(t, color=colour, linestyle=":", linewidth=1.0, zorder=2)
        top.plot(t, 1.0, "v", color=colour, markersize=8, transform=top.get_xaxis_transform(), clip_on=False,
                 zorder=5)  # fmt: skip
    for t, what in stops:
        for ax in axes:
            ax.axvline(t, color=STOP_COLOUR, linestyle="--", linewidth=1.3, zorder=2)
        top.annotate(what, (t, 1.0), xycoords=top.get_xaxis_transform(), xytext=(3, -3), textcoords="offset points",
                     rotation=90, va="top", fontsize=7, color=STOP_COLOUR)  # fmt: skip
    modes = list(dict.fromkeys(mode for _, _, mode in spans))
    handles: list[Patch | Line2D] = [
        Patch(facecolor=MODE_COLOURS.get(m, "#dee2e6"), alpha=0.5, label=f"mode {m}") for m in modes
    ]
    severities = list(dict.fromkeys(severity for _, severity in decisions))
    handles += [
        Line2D([], [], marker="v", linestyle=":", color=SEVERITY_COLOURS.get(s, "#343a40"), label=f"decision: {s}")
        for s in severities
    ]
    if stops:
        handles.append(Line2D([], [], linestyle="--", color=STOP_COLOUR, label="failsafe or stop"))
    fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 5), fontsize=8, frameon=False)
    fig.suptitle(f"Flight over time ({len(modes)} modes, {len(decisions)} decisions, {len(stops)} stops)", fontsize=10)
    return fig


__all__ = ["draw_flight", "mode_spans", "plot_flight", "read_samples"]
