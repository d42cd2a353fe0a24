"""The one polygon geometry: even-odd with edges inside, against an independent winding-number count and exact
cases on edges, corners and holes; and no second point-in-polygon test left in the project."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agentic_core.contracts import polygon as polygon_module
from agentic_core.contracts.polygon import (
    Ring,
    crossing_parity,
    distance_to_edge,
    outside_by,
    point_in_polygon,
    points_in_circle,
    points_in_polygon,
    polygon_area,
)

ROOT = Path(polygon_module.__file__).resolve().parents[2]
SQUARE = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]
U_SHAPE = [(0.0, 0.0), (9.0, 0.0), (9.0, 9.0), (6.0, 9.0), (6.0, 3.0), (3.0, 3.0), (3.0, 9.0), (0.0, 9.0)]


def winding_number(point: tuple[float, float], corners: list[tuple[float, float]]) -> int:
    """How many times the polygon winds round the point, by summing the angles it sweeps (another method)."""
    total = 0.0
    for (x1, y1), (x2, y2) in zip(corners, corners[1:] + corners[:1], strict=True):
        a1 = math.atan2(y1 - point[1], x1 - point[0])
        a2 = math.atan2(y2 - point[1], x2 - point[0])
        total += (a2 - a1 + math.pi) % (2 * math.pi) - math.pi
    return round(total / (2 * math.pi))


def test_edges_and_corners_count_as_inside() -> None:
    on_edges = [(5.0, 0.0), (10.0, 5.0), (5.0, 10.0), (0.0, 5.0), (0.0, 0.0), (10.0, 10.0), (10.0, 0.0)]
    assert points_in_polygon(on_edges, SQUARE).all()
    assert not points_in_polygon([(10.0 + 1e-3, 5.0), (5.0, -1e-3), (-1e-3, -1e-3)], SQUARE).any()


def test_the_notch_of_a_u_is_outside_and_its_rim_inside() -> None:
    assert point_in_polygon((4.5, 6.0), U_SHAPE) is False  # in the notch
    assert point_in_polygon((4.5, 3.0), U_SHAPE) is True  # on the notch's floor
    assert point_in_polygon((1.5, 8.0), U_SHAPE) and point_in_polygon((7.5, 8.0), U_SHAPE)
    assert point_in_polygon((3.0, 9.0), U_SHAPE)  # a corner at a ray's height


def test_a_ray_through_a_corner_is_counted_once() -> None:
    diamond = [(0.0, -5.0), (5.0, 0.0), (0.0, 5.0), (-5.0, 0.0)]
    assert points_in_polygon([(-4.0, 0.0), (-6.0, 0.0), (0.0, 0.0)], diamond).tolist() == [True, False, True]


def test_nan_points_and_empty_polygons_are_outside() -> None:
    assert points_in_polygon([(math.nan, 1.0), (1.0, math.nan)], SQUARE).tolist() == [False, False]
    assert points_in_polygon([(0.0, 0.0)], np.zeros((0, 2))).tolist() == [False]
    assert distance_to_edge([(1.0, 1.0)], np.zeros((0, 2))).tolist() == [math.inf]
    assert polygon_area([(0.0, 0.0), (1.0, 1.0)]) == 0.0


corner = st.tuples(st.floats(-100, 100), st.floats(-100, 100))


@settings(max_examples=300, deadline=None)
@given(st.lists(corner, min_size=3, max_size=9), st.lists(corner, min_size=1, max_size=20))
def test_agrees_with_the_winding_number_away_from_edges(
    corners: list[tuple[float, float]], points: list[tuple[float, float]]
) -> None:
    """Even-odd equals the winding number's parity for any polygon (self-crossing too) off its edges."""
    got = points_in_polygon(points, corners)
    away = distance_to_edge(points, corners) > 1e-6
    for point, inside, clear in zip(points, got, away, strict=True):
        if clear:
            assert bool(inside) == (winding_number(point, corners) % 2 == 1)
        else:
            assert inside


@settings(max_examples=200, deadline=None)
@given(st.floats(-50, 50), st.floats(-50, 50), st.floats(0.1, 30), st.integers(3, 12))
def test_regular_polygons_area_and_distance(cx: float, cy: float, r: float, k: int) -> None:
    angles = np.linspace(0.0, 2 * math.pi, k, endpoint=False)
    corners = np.column_stack([cx + r * np.cos(angles), cy + r * np.sin(angles)])
    assert polygon_area(corners) == pytest.approx(k / 2 * r * r * math.sin(2 * math.pi / k), rel=1e-9)
    assert polygon_area(corners[::-1]) == pytest.approx(polygon_area(corners))  # either winding
    apothem = r * math.cos(math.pi / k)
    assert distance_to_edge([(cx, cy)], corners)[0] == pytest.approx(apothem, rel=1e-9)
    assert point_in_polygon((cx, cy), corners.tolist())


@settings(max_examples=200, deadline=None)
@given(st.lists(corner, min_size=0, max_size=9), st.lists(corner, min_size=0, max_size=20))
def test_a_ring_answers_exactly_as_the_corners_do_and_keeps_its_own_copy(
    corners: list[tuple[float, float]], points: list[tuple[float, float]]
) -> None:
    """A :class:`Ring` is the same polygon, bit for bit, whatever is done afterwards to the corners it was made of;
    and nobody can change it through its arrays."""
    given_corners = np.array(corners, dtype=float).reshape(-1, 2)
    ring = Ring(given_corners)
    expected = [f(points, given_corners.copy()) for f in (points_in_polygon, distance_to_edge, crossing_parity)]
    area = polygon_area(given_corners)
    given_corners += 1.0  # the caller reuses its array
    for f, want in zip((points_in_polygon, distance_to_edge, crossing_parity), expected, strict=True):
        got = f(points, ring)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
    assert polygon_area(ring) == area
    both = ring.contains_and_distance(points)
    assert both[0].tobytes() == expected[0].tobytes() and both[1].tobytes() == expected[1].tobytes()
    away = ring.outside_by(points)
    inside, gap = points_in_polygon(points, ring), distance_to_edge(points, ring)
    assert away.tobytes() == np.where(inside, 0.0, gap).tobytes()  # exactly contains, then distance
    assert away.tolist() == pytest.approx([outside_by(p, corners) if corners else math.inf for p in points])
    with pytest.raises(ValueError, match="read-only"):
        ring.a[0:1] = 0.0


def test_circle_includes_its_rim() -> None:
    assert points_in_circle([(0.0, 5.0), (5.0, 0.0), (3.0, 4.0), (0.0, 5.0001)], (0.0, 0.0), 5.0).tolist() == [
        True,
        True,
        True,
        False,
    ]


def _looks_like_ray_casting(function: ast.FunctionDef) -> bool:
    """A body that flips or counts on ``(y1 > y) != (y2 > y)``: the crossing test of ray casting."""
    for node in ast.walk(function):
        if isinstance(node, ast.Compare) and any(isinstance(op, ast.NotEq) for op in node.ops):
            sides = [node.left, *node.comparators]
            if all(isinstance(s, ast.Compare) and isinstance(s.ops[0], ast.Gt | ast.Lt) for s in sides):
                return True
    return False


def test_no_other_point_in_polygon_in_the_project() -> None:
    found = []
    for top in ("agentic_core", "tools", "flight", "evaluation", "prompts"):
        for path in (ROOT / top).rglob("*.py"):
            if path == Path(polygon_module.__file__).resolve():
                continue
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.FunctionDef) and _looks_like_ray_casting(node):
                    found.append(f"{path.relative_to(ROOT)}: {node.name}")
    assert found == []
