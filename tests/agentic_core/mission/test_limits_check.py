"""``validate`` reports every limit a mission file breaks as written, whichever way a position is written (lat/lon,
north/east metres from home, an orbit's circle, a survey's corners and legs, a ``call_tool`` to a flight tool),
with the envelope the flight uses: same verdict, same words, each at its file:line:col and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from agentic_core.cli import main
from agentic_core.contracts.geodesy import offset_position
from agentic_core.mission.envelope import Envelope
from agentic_core.mission.source import MissionError
from agentic_core.mission.validate import load_mission

HOME = (21.4133, 39.8933)
CIRCLE = "geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 200}"


def mission(steps: str, limits: str = f"{{{CIRCLE}, max_altitude_m: 25}}") -> str:
    return f"plan_id: trap\ngoal: test the fence\nlimits: {limits}\nsteps:\n{steps}"


def col(text: str, line: int, field: str) -> str:
    """``line:col`` of ``field``'s value on a 1-based line of ``text`` (where a problem about it points)."""
    row = text.splitlines()[line - 1]
    return f"{line}:{row.index(f'{field}: ') + len(field) + 3}"


def problems(text: str, home: tuple[float, float] | None = HOME) -> list[str]:
    try:
        load_mission(text, file="m.yaml", home=home)
    except MissionError as exc:
        return [str(p) for p in exc.problems]
    return []


def test_a_north_east_waypoint_15_m_past_the_fence_is_refused_by_validate_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "trap.yaml"
    text = mission("  - {id: up, action: takeoff, args: {altitude_m: 10}}\n"
                   "  - {id: out, action: fly_to, args: {north_m: 215, east_m: 0, alt_m: 10}}\n")  # fmt: skip
    path.write_text(text)
    assert main(["validate", str(path), "--no-builtins"]) == 2
    err = capsys.readouterr().err
    assert f"{path}:{col(text, 6, 'north_m')}: fly_to: the destination is 15 m outside the geofence" in err, err
    inside = tmp_path / "inside.yaml"
    inside.write_text(path.read_text().replace("north_m: 215", "north_m: 185"))
    assert main(["validate", str(inside), "--no-builtins"]) == 0, capsys.readouterr().err


def test_home_moves_with_the_option_and_the_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m.yaml"
    path.write_text(mission("  - {id: out, action: fly_to, args: {north_m: 150, east_m: 0, alt_m: 10}}\n"))
    assert main(["validate", str(path), "--no-builtins"]) == 0
    moved = ",".join(str(v) for v in offset_position(*HOME, 100.0, 0.0))  # home 100 m north: the point is 250 m out
    assert main(["validate", str(path), "--no-builtins", "--home", moved]) == 2
    assert "50 m outside the geofence" in capsys.readouterr().err
    for bad in ("21.4", "north,east", "91,0"):
        assert main(["validate", str(path), "--no-builtins", "--home", bad]) == 2
        assert "--home takes LAT,LON" in capsys.readouterr().err


def test_every_way_of_writing_a_place_or_a_height_is_seen_at_once() -> None:
    lat, lon = offset_position(*HOME, 0.0, 260.0)
    text = mission(
        f"""  - {{id: up, action: takeoff, args: {{altitude_m: 30}}}}
  - {{id: ll, action: fly_to, args: {{lat: {lat}, lon: {lon}, alt_m: 10}}}}
  - {{id: low, action: fly_to, args: {{north_m: 10, east_m: 0, alt_m: 1}}}}
  - {{id: ring, action: orbit, args: {{center: {{lat: 21.4133, lon: 39.8933}}, radius_m: 250, alt_m: 10}}}}
  - {{id: down, action: land, args: {{lat: {lat}, lon: {lon}}}}}
  - {{id: tool, action: call_tool, tool: flight.fly_to, args: {{north_m: -230, east_m: 0}}}}
  - id: patrol
    action: repeat
    until: "patrol.iterations >= 1"
    steps: [{{id: deep, action: fly_to, args: {{north_m: 0, east_m: -300, alt_m: 40}}}}]
"""
    )
    assert problems(text) == [
        f"m.yaml:{col(text, 5, 'altitude_m')}: takeoff: altitude_m 30 m is above the ceiling of 25 m"
        " (limits.max_altitude_m)",
        f"m.yaml:{col(text, 6, 'lat')}: fly_to: the destination is 60 m outside the geofence",
        f"m.yaml:{col(text, 7, 'alt_m')}: fly_to: alt_m 1 m is below the floor of 2 m above home",
        f"m.yaml:{col(text, 8, 'radius_m')}: orbit: the orbit of radius 250 m leaves the geofence",
        f"m.yaml:{col(text, 9, 'lat')}: land: the landing place is 60 m outside the geofence",
        f"m.yaml:{col(text, 10, 'north_m')}: call_tool: the destination is 30 m outside the geofence",
        f"m.yaml:{col(text, 14, 'north_m')}: fly_to: the destination is 100 m outside the geofence",
        f"m.yaml:{col(text, 14, 'alt_m')}: fly_to: alt_m 40 m is above the ceiling of 25 m (limits.max_altitude_m)",
    ]


def test_the_verdict_is_the_flight_envelopes_own() -> None:
    """One geometry: for points around the fence, validate refuses exactly what the envelope refuses in flight."""
    envelope = Envelope(load_mission(mission("  - {id: h, action: hover, args: {duration_s: 1}}\n")).limits,
                        home=lambda: HOME)  # fmt: skip
    for north in (150.0, 199.0, 200.5, 201.5, 260.0):
        for east in (-120.0, 0.0, 140.0):
            step = f"  - {{id: p, action: fly_to, args: {{north_m: {north}, east_m: {east}, alt_m: 10}}}}\n"
            in_flight = envelope.check("flight.fly_to", {"north_m": north, "east_m": east, "alt_m": 10.0})
            assert [p.split(": ", 2)[2] for p in problems(mission(step))] == in_flight, (north, east)


def test_a_survey_inside_a_concave_fence_whose_legs_cross_its_notch_is_refused() -> None:
    # a U-shaped fence open to the north; the survey's corners stand in its arms, but its diagonal edge (where the
    # lawnmower legs end) crosses the notch between them
    u = [(0, 0), (0, 300), (300, 300), (300, 200), (100, 200), (100, 100), (300, 100), (300, 0)]
    fence = ", ".join("{{lat: {}, lon: {}}}".format(*offset_position(*HOME, n, e)) for n, e in u)
    area = [(120, 50), (290, 50), (290, 250)]
    polygon = ", ".join("{{lat: {}, lon: {}}}".format(*offset_position(*HOME, n, e)) for n, e in area)
    text = mission(
        f"  - {{id: s, action: survey, args: {{polygon: [{polygon}], altitude_m: 20, spacing_m: 30}}}}\n",
        f"{{geofence: [{fence}], max_altitude_m: 25}}",
    )
    found = problems(text)
    assert len(found) == 1 and "survey: leg point " in found[0] and "m outside the geofence" in found[0], found
    assert found[0].startswith(f"m.yaml:{col(text, 5, 'polygon')}")
    high = problems(text.replace("altitude_m: 20", "altitude_m: 30"))
    assert (
        f"m.yaml:{col(text, 5, 'altitude_m')}: survey: altitude_m 30 m is above the ceiling of 25 m"
        " (limits.max_altitude_m)" in high
    )


def test_what_is_known_only_in_flight_is_left_to_the_flight() -> None:
    text = mission(
        """  - {id: t, action: fly_to, args: {target_id: P-1, alt_m: 10}}
  - {id: tpl, action: fly_to, args: {north_m: "${params.far}", east_m: 0, alt_m: "${params.high}"}}
""",
    ).replace("steps:", "params: {far: {default: 900}, high: {default: 500}}\nsteps:")
    assert problems(text) == []
    # without a home, north/east cannot be placed against a lat/lon fence: not guessed, left to the flight
    assert problems(mission("  - {id: o, action: fly_to, args: {north_m: 900, east_m: 0, alt_m: 10}}\n"), None) == []
