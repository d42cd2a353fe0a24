"""Filters of ``find()``/``count()``: a misspelt operator or World Model field is refused when the mission loads,
and again when a filter is applied, never read as a field compared with ``==`` (a trigger that could never fire)."""

from pathlib import Path

import pytest

from agentic_core.contracts.world_model import WorldModel
from agentic_core.mission import MissionError, load_mission
from agentic_core.mission.expressions import Expression, ExpressionError
from agentic_core.mission.functions import FILTER_OPERATORS, count, find

REPO = Path(__file__).resolve().parents[3]
EMERGENCY = REPO / "missions" / "hajj_emergency.yaml"


def _world(stationary_s: float) -> WorldModel:
    pose = {"north": 5, "east": -3, "down": 0, "lat": 21.41335, "lon": 39.89327, "alt": 0}
    return WorldModel.model_validate({
        "timestamp": 1.0,
        "ego_pose": {"north": 0, "east": 0, "down": -30, "lat": 21.4133, "lon": 39.8933, "alt": 30},
        "objects": [{"id": "P-1", "class": "person", "conf": 0.9, "pose": pose, "stationary_s": stationary_s}],
        "relations": [{"subj": "P-1", "pred": "isolated_from", "obj": "crowd"}],
    })  # fmt: skip


def _problems(text: str, file: str = "typo.yaml") -> list[str]:
    with pytest.raises(MissionError) as caught:
        load_mission(text, file=file)
    return [f"{p.file}:{p.line}:{p.col}: {p.message}" for p in caught.value.problems]


def test_the_shipped_emergency_mission_with_a_misspelt_operator_fails_to_load_at_its_line() -> None:
    text = EMERGENCY.read_text(encoding="utf-8")
    assert text.count("stationary_s__gte") >= 1
    typo = text.replace("stationary_s__gte", "stationary_s__ge", 1)
    line = next(i for i, row in enumerate(typo.splitlines(), 1) if "stationary_s__ge=" in row)
    problems = _problems(typo)
    assert len(problems) == 1, problems
    assert problems[0].startswith(f"typo.yaml:{line}:")
    assert "unknown filter operator 'ge'" in problems[0]
    assert "did you mean 'stationary_s__gte'?" in problems[0]
    assert all(op in problems[0] for op in FILTER_OPERATORS)


@pytest.mark.parametrize("name", ["conf__gtee", "conf__above", "stationary_s__GTE", "id__notin"])
def test_every_unknown_operator_is_refused_when_parsed(name: str) -> None:
    text = f"count(world.objects, {name}=1)"
    with pytest.raises(ExpressionError) as caught:
        Expression.parse(text)
    assert f"unknown filter operator {name.rpartition('__')[2]!r}" in caught.value.message
    assert caught.value.col == text.index(name)


def test_a_misspelt_operator_is_an_error_when_evaluated_not_a_field_compared_with_eq() -> None:
    # a filter built at run time (not through a parsed expression) must not fall back to ==
    items = [{"stationary_s__ge": 10, "stationary_s": 12}]
    with pytest.raises(ValueError, match="unknown filter operator 'ge'"):
        count(items, stationary_s__ge=10)
    with pytest.raises(ValueError, match="unknown filter operator 'ge'"):
        find(_world(12.0), class_="person", stationary_s__ge=10)


def test_every_known_operator_still_works() -> None:
    world = _world(12.0)
    for op, wanted, expected in [("eq", 12.0, 1), ("ne", 12.0, 0), ("gt", 11, 1), ("gte", 12, 1), ("lt", 12, 0),
                                 ("lte", 12, 1), ("in", [12.0, 3.0], 1)]:  # fmt: skip
        assert count(world.objects, **{f"stationary_s__{op}": wanted}) == expected, op
    assert len(find(world, class___ne="vehicle", relation="isolated_from")) == 1


def test_a_misspelt_world_model_field_fails_to_load_with_the_closest_field() -> None:
    text = (
        "plan_id: P\ngoal: g\nsteps: [{id: up, action: takeoff}]\ntriggers:\n"
        '  - id: t\n    when: "count(find(world), stationary_sec__gte=5) > 0"\n'
        "    steps: [{id: look, action: analyze_scene}]\n"
    )
    problems = _problems(text)
    assert len(problems) == 1 and problems[0].startswith("typo.yaml:6:"), problems
    assert "no field 'stationary_sec'" in problems[0] and "did you mean 'stationary_s'?" in problems[0]


def test_a_misspelt_field_of_a_world_model_object_is_an_error_when_evaluated() -> None:
    with pytest.raises(ValueError, match=r"no field 'stationary_sec'.*did you mean 'stationary_s'"):
        find(_world(12.0), stationary_sec__gte=5)
    expr = Expression.parse("count(items, stationary_sec__gte=5)")  # the items are not known to be objects here
    with pytest.raises(ExpressionError, match="no field 'stationary_sec'"):
        expr.evaluate({"items": _world(12.0).objects})


def test_fields_world_model_objects_have_are_accepted_and_other_items_keep_their_own() -> None:
    ok = "find(world, class_='person', cls='person', stationary_s__gte=1, sigma_m__lt=9, relation='isolated_from')"
    assert Expression.parse(ok).evaluate({"world": _world(12.0)})
    # plain mappings may carry any fields: a key one of them lacks is no match, not an error
    assert Expression.parse("count(items, colour='red')").evaluate({"items": [{"colour": "red"}, {}]}) == 1
