"""The one located problem: its printed form with and without a position, its order, its refusals, and that
missions and scenes report through it (one class, not look-alikes)."""

from __future__ import annotations

from pathlib import Path

import pytest

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.problems import LocatedProblem, ProblemsError
from agentic_core.mission import MissionError, Problem, load_mission
from flight.sim.scene_file import SceneFileError, SceneProblem, load_scene


@pytest.mark.parametrize(
    ("problem", "printed"),
    [
        (LocatedProblem("m.yaml", 3, 7, "bad"), "m.yaml:3:7: bad"),
        (LocatedProblem("m.yaml", 3, None, "bad"), "m.yaml:3: bad"),
        (LocatedProblem("m.yaml", None, None, "bad"), "m.yaml: bad"),
        (LocatedProblem("", None, None, "bad"), "bad"),
        (LocatedProblem("C:/x:y.yaml", 1, 1, "a: b"), "C:/x:y.yaml:1:1: a: b"),
    ],
)
def test_printed_as_file_line_col_message(problem: LocatedProblem, printed: str) -> None:
    assert str(problem) == printed


@pytest.mark.parametrize(("line", "col"), [(0, 1), (1, 0), (-3, None), (None, 4), (True, 1), (1.5, 1)])
def test_positions_are_one_based_and_a_column_needs_its_line(line: object, col: object) -> None:
    with pytest.raises(ValueError, match=r"1-based|needs its line"):
        LocatedProblem("f.yaml", line, col, "x")  # type: ignore[arg-type]


def test_the_error_lists_every_problem_in_file_order() -> None:
    found = [
        LocatedProblem("b.yaml", 1, 1, "later file"),
        LocatedProblem("a.yaml", 10, 2, "third"),
        LocatedProblem("a.yaml", 2, 9, "second"),
        LocatedProblem("a.yaml", None, None, "first: the whole file"),
    ]
    error = ProblemsError(found)
    assert [p.message for p in error.problems] == ["first: the whole file", "second", "third", "later file"]
    assert str(error).splitlines() == [str(p) for p in error.problems]
    assert isinstance(error, InputError) and error.exit_status == 2


def test_an_error_without_problems_is_refused() -> None:
    with pytest.raises(ValueError):
        ProblemsError([])


def test_missions_and_scenes_report_through_the_one_type(tmp_path: Path) -> None:
    assert Problem is LocatedProblem and SceneProblem is LocatedProblem
    assert issubclass(MissionError, ProblemsError) and issubclass(SceneFileError, ProblemsError)
    mission = tmp_path / "m.yaml"
    mission.write_text("plan_id: P-1\ngoal: g\nsteps:\n  - {id: up, action: takeof}\n")
    with pytest.raises(MissionError) as caught:
        load_mission(mission)
    assert all(type(p) is LocatedProblem for p in caught.value.problems)
    assert str(caught.value).startswith(f"{mission}:4:")
    with pytest.raises(SceneFileError) as scene_caught:
        load_scene("id: s\nzones: 3\n", file="s.yaml")
    assert all(type(p) is LocatedProblem for p in scene_caught.value.problems)
    assert str(scene_caught.value).startswith("s.yaml:2:")
