"""The report's plots, tried against what makes plots bad: labels piled on one spot, a scene whose landmarks
crowd the flight, a run with no telemetry or a telemetry file cut by a kill, a flight of one sample."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from agentic_core.contracts import TelemetrySample
from agentic_core.run.plots.flight import draw_flight, mode_spans, plot_flight, read_samples
from agentic_core.run.plots.labels import LabelPlacer
from agentic_core.run.plots.trajectory import draw_trajectory, plot_trajectory, time_marks, view
from agentic_core.run.report import TrackPoint, landing_spot
from flight.sim.scene_file import load_scene
from flight.sim.scene_model import Scene

SCENES = Path(__file__).parent / "scenes"
PNG = b"\x89PNG\r\n\x1a\n"


def a_flight(seconds: float = 120.0, hz: float = 10.0) -> list[TrackPoint]:
    """Up to 30 m, out 40 m north and 15 m east, down beside the casualty, back home."""
    points = []
    for i in range(int(seconds * hz) + 1):
        t = i / hz
        f = t / seconds
        out = math.sin(math.pi * f)
        points.append(TrackPoint(sim_t=t, north_m=40 * out, east_m=15 * out, alt_m=30 * min(1.0, 4 * out)))
    return points


def crowded(scene: Scene, n: int) -> Scene:
    """``scene`` with ``n`` more landmarks heaped on the casualty's spot, each with a long name."""
    at = scene.actor(scene.ground_truth.casualties[0]).position
    extra = [
        {"id": f"Pole-{i}", "kind": "other", "name": f"Lamp post number {i}",
         "position": {"north": at.north + 0.5 * (i % 3), "east": at.east + 0.5 * (i // 3)}}
        for i in range(n)
    ]  # fmt: skip
    data = scene.model_dump(mode="json", by_alias=True)
    data["landmarks"] += extra
    return Scene.model_validate(data)


def test_labels_heaped_on_one_point_never_overlap_and_those_that_must_show_do() -> None:
    fig = Figure(figsize=(4, 4))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlim(0, 10)
    ax.set_ylim(0, 10)
    placer = LabelPlacer(ax)
    shown = [placer.place(5, 5, f"label {i}") for i in range(40)]
    assert 8 <= sum(s is not None for s in shown) < 40  # the free spots are used, the rest left out
    assert placer.overlaps() == 0
    must = placer.place(5, 5, "must be seen", must=True)
    assert must is not None and "must be seen" in placer.texts


def test_the_trajectory_over_a_crowded_scene_has_every_key_label_and_none_overlapping(tmp_path: Path) -> None:
    scene = crowded(load_scene(SCENES / "near_emergency.yaml"), 12)
    track = a_flight()
    fig, placer = draw_trajectory(track, scene, landing_spot(track))
    assert placer.overlaps() == 0
    texts = placer.texts
    for casualty in scene.ground_truth.casualties:
        assert casualty in texts
    assert any(t.startswith("start") for t in texts) and any(t.startswith("end") for t in texts)
    assert [t for t in texts if t.endswith(" s") and t[0].isdigit()], "no time along the track"
    assert any(t.startswith("Lamp post") for t in texts), "every landmark label was dropped"
    # the track is in view, with its colour scale (altitude), and the zones crossing the view are drawn
    (ax, colorbar) = fig.axes
    (east, north) = ax.get_xlim(), ax.get_ylim()
    assert all(east[0] <= p.east_m <= east[1] and north[0] <= p.north_m <= north[1] for p in track)
    assert "altitude" in colorbar.get_ylabel()
    assert len(ax.patches) >= 2
    path = plot_trajectory(track, scene, tmp_path / "trajectory.png", landing_spot(track))
    assert path.read_bytes()[:8] == PNG


@pytest.mark.parametrize("points", [0, 1, 2], ids=["no-track", "one-point", "two-points"])
def test_a_trajectory_of_almost_nothing_still_draws(tmp_path: Path, points: int) -> None:
    track = a_flight(seconds=1.0, hz=1.0)[:points]
    for scene in (None, load_scene(SCENES / "near_emergency.yaml")):
        path = plot_trajectory(track, scene, tmp_path / f"t{points}.png", None)
        assert path.read_bytes()[:8] == PNG


def test_time_marks_are_round_few_and_inside_the_flight() -> None:
    for seconds in (20.0, 95.0, 600.0, 3000.0):
        track = a_flight(seconds=seconds, hz=2.0)
        marks = time_marks(track)
        assert 1 <= len(marks) <= 8, (seconds, len(marks))
        steps = {round(b.sim_t - a.sim_t, 6) for a, b in itertools.pairwise(marks)}
        assert len(steps) <= 1 and all(m.sim_t % next(iter(steps or {m.sim_t})) == 0 for m in marks)
        assert track[0].sim_t < marks[0].sim_t and marks[-1].sim_t < track[-1].sim_t


def test_the_view_holds_home_the_track_and_the_casualty_and_is_square() -> None:
    scene = load_scene(SCENES / "near_emergency.yaml")
    track = [TrackPoint(sim_t=0, north_m=-300, east_m=5, alt_m=0), TrackPoint(sim_t=1, north_m=-310, east_m=9, alt_m=0)]
    east, north = view(track, scene)
    casualty = scene.actor("P-12").position
    for e, n in [(0, 0), (5, -300), (9, -310), (casualty.east, casualty.north)]:
        assert east[0] < e < east[1] and north[0] < n < north[1]
    assert east[1] - east[0] == pytest.approx(north[1] - north[0])


def sample(t: float, mode: str, **fields: Any) -> TelemetrySample:
    base: dict[str, Any] = dict(lat_deg=21.4, lon_deg=39.9, alt_m=10.0, north_m=0, east_m=0, down_m=-10,
                                battery_pct=90.0, armed=True)  # fmt: skip
    return TelemetrySample(time_s=t, mode=mode, **{**base, **fields})


def test_mode_spans_cover_the_flight_without_gaps_and_follow_every_change() -> None:
    modes = ["hold"] * 3 + ["takeoff"] * 5 + ["hold"] + ["rtl"] * 4
    samples = [sample(float(t), m) for t, m in enumerate(modes)]
    spans = mode_spans(samples)
    assert [m for *_, m in spans] == ["hold", "takeoff", "hold", "rtl"]
    assert spans[0][0] == 0 and spans[-1][1] == len(modes) - 1
    assert all(a[1] == b[0] for a, b in itertools.pairwise(spans))
    assert mode_spans([]) == []


def test_a_telemetry_file_cut_by_a_kill_or_missing_reads_what_is_whole(tmp_path: Path) -> None:
    path = tmp_path / "telemetry.jsonl"
    assert read_samples(path) == []
    good = [sample(float(t), "hold") for t in range(5)]
    text = "".join(s.model_dump_json() + "\n" for s in good)
    path.write_text(text + good[0].model_dump_json()[:40] + "\n" + json.dumps({"time_s": "x"}) + "\n")
    assert read_samples(path) == good


def test_the_flight_plot_marks_modes_decisions_and_stops(tmp_path: Path) -> None:
    samples = [sample(t / 2, "takeoff" if t < 20 else "hold" if t < 60 else "rtl", alt_m=t / 4, vn_mps=3.0,
                      battery_pct=100 - t / 10) for t in range(100)]  # fmt: skip
    records: list[dict[str, Any]] = [
        {"kind": "decision", "sim_t": 12.0, "assessment": {"severity": "high"}},
        {"kind": "decision", "sim_t": 20.0, "assessment": None, "error": "timeout"},
        {"kind": "failsafe", "sim_t": 30.0, "failsafe": "battery", "action": "rtl"},
        {"kind": "control", "sim_t": 31.0, "command": "rtl", "by": "operator"},
        {"kind": "control", "sim_t": 32.0, "command": "pause", "by": "operator"},  # not a stop
        {"kind": "decision", "assessment": {"severity": "low"}},  # no time: not drawn
    ]
    fig = draw_flight(samples, records)
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert legend == ["mode takeoff", "mode hold", "mode rtl", "decision: high", "decision: error", "failsafe or stop"]
    top = fig.axes[0]
    notes = [t.get_text() for t in top.texts]
    assert notes == ["failsafe: battery → rtl", "rtl by operator"]
    marked = sorted(
        {float(np.asarray(line.get_xdata())[0]) for line in top.lines if line.get_linestyle() in (":", "--")}
    )
    assert marked == [12.0, 20.0, 30.0, 31.0]
    assert [len(ax.patches) for ax in fig.axes] == [3, 3, 3]  # one band per stretch of a mode, on every axis
    path = plot_flight(samples, records, tmp_path / "flight.png")
    assert path.read_bytes()[:8] == PNG
    empty = plot_flight([], records, tmp_path / "empty.png")
    assert empty.read_bytes()[:8] == PNG
    one = plot_flight(samples[:1], [], tmp_path / "one.png")
    assert one.read_bytes()[:8] == PNG
