"""Mission loading is bounded and says what it read: at most MAX_STEPS steps and lists of at most
MAX_LIST_ITEMS (each refused at the first step or item past it, before a large text is built), numbers as YAML
1.2 writes them (YAML 1.1's 1:30, 0x1F, 012 and 1_000 are not silently numbers), and schema errors that name what
the author wrote, not pydantic's union members."""

import random
import tracemalloc
from typing import Any

import pytest
import yaml

from agentic_core.contracts.mission_values import MAX_POINTS
from agentic_core.contracts.policy_graph import MAX_STEPS, PolicyGraph
from agentic_core.mission import MissionError, load_mission
from agentic_core.mission.source import SourceMap, _Loader, load_document
from agentic_core.mission.step_bound import (
    EVENT_COUNT_FROM,
    LIST_OVER_MESSAGE,
    MAX_LIST_ITEMS,
    MAX_VALUES,
    VALUES_OVER_MESSAGE,
    count_over,
    first_past_bounds,
    step_paths,
)

HEAD = "plan_id: t\ngoal: x\nsteps:\n  - {id: s0, action: takeoff}\n"
STEPS = HEAD[HEAD.index("steps:") :]


def chain(count: int, goal: str = "x") -> str:
    """A valid mission of ``count`` steps, each waiting for the one before (one step per line from line 4)."""
    lines = [
        f"  - {{id: s{i}, action: hover, depends_on: [s{i - 1}], args: {{duration_s: 1}}}}\n" for i in range(1, count)
    ]
    return f"plan_id: t\ngoal: {goal}\nsteps:\n  - {{id: s0, action: takeoff}}\n" + "".join(lines)


def problems(text: str) -> list[str]:
    with pytest.raises(MissionError) as info:
        load_mission(text, file="m.yaml")
    return [str(p) for p in info.value.problems]


def refused_once(text: str) -> tuple[Any, int]:
    """The one problem a large text is refused with, and the peak of memory allocated while refusing it."""
    tracemalloc.start()
    try:
        with pytest.raises(MissionError) as info:
            load_document(text, "big.yaml")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    [problem] = info.value.problems
    return problem, peak


# ---- the bound on steps ----


def test_a_mission_at_the_bound_loads_and_one_step_more_is_refused_at_that_step() -> None:
    assert len(load_mission(chain(MAX_STEPS)).steps) == MAX_STEPS
    found = problems(chain(MAX_STEPS + 1))
    line = 4 + MAX_STEPS  # the first step is on line 4
    assert found == [
        f"m.yaml:{line}:5: a mission has at most {MAX_STEPS:,} steps, nested and trigger steps included; this is "
        f"step {MAX_STEPS + 1:,} of {MAX_STEPS + 1:,} (split the mission, or use a repeat for a patrol)"
    ]


def test_a_large_mission_is_refused_before_it_is_built() -> None:
    """40,000 steps (3 MB): the old loader built them all (and validation took hundreds of MB, 12.7 GB at 30 MB);
    now reading stops at the step past the bound."""
    text = chain(40_000)
    assert len(text) > EVENT_COUNT_FROM
    problem, peak = refused_once(text)
    assert (problem.line, problem.col) == (4 + MAX_STEPS, 5)
    assert f"at most {MAX_STEPS:,} steps" in problem.message
    assert peak < 20 * 2**20, f"refusing took {peak / 2**20:.0f} MB"


def test_nested_trigger_and_aliased_steps_count() -> None:
    nested = (
        "  - {id: r, action: repeat, until: 'true', steps: ["
        + ", ".join(f"{{id: n{i}, action: hover, args: {{duration_s: 1}}}}" for i in range(MAX_STEPS))
        + "]}\n"
    )
    assert any("at most" in p for p in problems(HEAD + nested))
    trigger = (
        "triggers:\n  - {id: t, when: 'true', steps: ["
        + ", ".join(f"{{id: t{i}, action: rtl}}" for i in range(MAX_STEPS))
        + "]}\n"
    )
    assert any("at most" in p for p in problems(HEAD + trigger))
    aliased = "plan_id: t\ngoal: x\nsteps:\n  - &h {id: s, action: rtl}\n" + "  - *h\n" * MAX_STEPS
    assert any("at most" in p for p in problems(aliased))


def test_a_plan_built_in_code_is_bounded_too() -> None:
    steps = [{"id": f"s{i}", "action": "rtl"} for i in range(MAX_STEPS + 1)]
    with pytest.raises(ValueError, match=f"at most {MAX_STEPS:,} steps.*this one has {MAX_STEPS + 1:,}"):
        PolicyGraph.model_validate({"plan_id": "p", "goal": "g", "steps": steps})


def _random_mission(rng: random.Random, total: int) -> dict[str, Any]:
    """About ``total`` steps spread over the plan, repeat and branch bodies and triggers, with other lists
    (depends_on, preconditions, a geofence) in between: the event counter must tell which lists hold steps."""
    counter = iter(range(10**6))

    def body(depth: int, size: int) -> list[dict[str, Any]]:
        items: list[dict[str, Any]] = []
        while size > 0:
            kind, ident = rng.random(), f"s{next(counter)}"
            if depth < 3 and kind < 0.05 and size > 2:
                inner = rng.randint(1, size - 1)
                items.append({"id": ident, "action": "repeat", "until": "true", "steps": body(depth + 1, inner)})
                size -= inner + 1
            elif depth < 3 and kind < 0.1 and size > 3:
                then, other = rng.randint(1, size // 2), rng.randint(0, size // 2 - 1)
                step = {"id": ident, "action": "branch", "if": "true", "then": body(depth + 1, then)}
                items.append({**step, "else": body(depth + 1, other)} if other else step)
                size -= then + other + 1
            else:
                items.append({"id": ident, "action": "hover", "preconditions": ["true"], "args": {"duration_s": 1}})
                size -= 1
        return items

    in_triggers = rng.randint(0, total // 2)
    triggers: list[dict[str, Any]] = []
    while in_triggers > 0:
        size = rng.randint(1, in_triggers)
        triggers.append({"id": f"t{next(counter)}", "when": "true", "steps": body(0, size)})
        in_triggers -= size
    fence = [{"lat": 0, "lon": 0}, {"lat": 0, "lon": 1}, {"lat": 1, "lon": 0}]
    mission: dict[str, Any] = {"plan_id": "t", "goal": "x", "limits": {"geofence": fence}}
    mission["steps"] = body(0, total - sum(1 for _ in step_paths({"triggers": triggers})))
    if rng.random() < 0.5:  # triggers before the steps, or after
        return {"triggers": triggers, **mission} if triggers else mission
    return {**mission, "triggers": triggers} if triggers else mission


@pytest.mark.parametrize("seed", range(16))
def test_the_event_count_and_the_data_count_find_the_same_step(seed: int) -> None:
    """Hostile: missions shaped at random, nested and in triggers, in block or flow style, at, under or past the
    bound; reading events (large texts) and walking the data (every text) must agree on the step past the bound,
    to the line and column, and on whether there is one."""
    rng = random.Random(seed)
    mission = _random_mission(rng, rng.choice([MAX_STEPS - 1, MAX_STEPS, MAX_STEPS + 1, MAX_STEPS + 50]))
    text = yaml.safe_dump(mission, sort_keys=False, default_flow_style=rng.choice([None, False]), width=100)
    loader = _Loader(text)
    try:
        by_events = first_past_bounds(loader)
    finally:
        loader.dispose()
    over = count_over(yaml.safe_load(text))
    assert (by_events is None) == (over is None), (by_events, over)
    if over is not None:
        assert by_events is not None and by_events[:2] == SourceMap("m.yaml", text=text).at(over[0])
        assert over[1] == sum(1 for _ in step_paths(mission)) > MAX_STEPS


# ---- the bound on a list ----


def points(count: int, indent: str) -> str:
    """``count`` polygon points, one a line, the first at column ``len(indent) + 3`` (past the ``- ``)."""
    return "".join(f"{indent}- {{lat: {21.41 + i * 1e-7:.7f}, lon: 39.89}}\n" for i in range(count))


def fenced(count: int) -> str:
    """A mission whose geofence has ``count`` points, the first on line 5."""
    return f"plan_id: t\ngoal: x\nlimits:\n  geofence:\n{points(count, '    ')}" + STEPS


def test_a_fence_at_the_bound_loads_and_one_point_more_is_refused_at_that_point() -> None:
    assert MAX_LIST_ITEMS == MAX_POINTS
    fence = load_mission(fenced(MAX_POINTS)).limits.geofence
    assert isinstance(fence, list) and len(fence) == MAX_POINTS
    assert problems(fenced(MAX_POINTS + 1)) == [f"m.yaml:{5 + MAX_POINTS}:7: {LIST_OVER_MESSAGE}"]


def test_a_30_mb_fence_is_refused_at_the_point_past_the_bound_before_it_is_built() -> None:
    """Hostile: 850,000 points, 30 MB, under the 32 MB input bound: checking them took 80 s and 2.1 GB. Reading now
    stops at the point past the bound."""
    text = fenced(850_000)
    assert len(text) > 30 * 10**6
    problem, peak = refused_once(text)
    assert (problem.line, problem.col, problem.message) == (5 + MAX_POINTS, 7, LIST_OVER_MESSAGE)
    # the YAML reader copies the text once (it appends a NUL): a copy of what was read, no more
    assert peak < len(text) + 20 * 2**20, f"refusing took {peak / 2**20:.0f} MB"


@pytest.mark.parametrize("large", [False, True], ids=["built", "read-from-events"])
def test_any_list_past_the_bound_is_refused_where_it_is_in_a_small_text_or_a_large_one(large: bool) -> None:
    """The same refusal, at the same place, whether the text is read from its events (a megabyte or more: padded
    here by a comment at its end) or built first."""
    many = ", ".join(["'true'"] * (MAX_LIST_ITEMS + 1))
    text = f"{HEAD}  - {{id: h, action: hover, preconditions: [{many}], args: {{duration_s: 1}}}}\n"
    if large:
        text += "# " + "x" * EVENT_COUNT_FROM + "\n"
    [problem] = problems(text)
    col = text.splitlines()[4].index("'true'") + 1 + len("'true', ") * MAX_LIST_ITEMS
    assert problem == f"m.yaml:5:{col}: {LIST_OVER_MESSAGE}"


def surveys(count: int, points_each: int) -> str:
    """A mission of ``count`` survey steps, each over ``points_each`` points (four values a point), one a line."""
    area = "".join(f"        - {{lat: {21.41 + i * 1e-7:.7f}, lon: 39.89}}\n" for i in range(points_each))
    step = "    action: survey\n    args:\n      altitude_m: 20\n      polygon:\n" + area
    return "plan_id: t\ngoal: x\nsteps:\n" + "".join(f"  - id: s{k}\n" + step for k in range(count))


@pytest.mark.parametrize("large", [False, True], ids=["built", "read-from-events"])
def test_values_past_the_bound_are_refused_at_the_first_one_past_it(large: bool) -> None:
    """Many lists each within their bound still hold a bound in all: 11 steps of 9,500 values each (a step's id and
    action are values too; keys are not), refused at value 100,001, where it is, built or read from events."""
    count, each = 11, 9_500
    lines = [f"  - {{id: s{k}, action: hover, preconditions: [{', '.join(['1'] * each)}]}}" for k in range(count)]
    text = "plan_id: t\ngoal: x\nsteps:\n" + "\n".join(lines) + "\n"
    if large:
        text += "# " + "x" * EVENT_COUNT_FROM + "\n"
    else:
        assert len(text) < EVENT_COUNT_FROM
    left = MAX_VALUES + 1 - 2  # plan_id's and goal's values come first
    for k in range(count):
        left -= 2  # the step's id and action
        if left <= each:
            line, col = 4 + k, lines[k].index("[") + 2 + 3 * (left - 1)
            break
        left -= each
    assert problems(text) == [f"m.yaml:{line}:{col}: {VALUES_OVER_MESSAGE}"]


def test_a_30_mb_mission_of_many_large_polygons_is_refused_before_it_is_built() -> None:
    """Hostile: 75 surveys of 10,000 points each, every list within its bound, 30 MB: validating took 22 s and
    2 GB; reading now stops at the value past the bound."""
    text = surveys(75, 10_000)
    assert len(text) > 30 * 10**6
    problem, peak = refused_once(text)
    assert problem.message == VALUES_OVER_MESSAGE
    assert peak < len(text) + 20 * 2**20, f"refusing took {peak / 2**20:.0f} MB"


def test_survey_and_swarm_areas_are_bounded_built_in_code_too() -> None:
    """A plan built in code, not read from a file, holds the polygons' bound in its contract."""
    corner = {"lat": 21.41, "lon": 39.89}
    survey = {"id": "s", "action": "survey", "args": {"polygon": [corner] * (MAX_POINTS + 1), "altitude_m": 20}}
    with pytest.raises(ValueError, match="at most 10000 items"):
        PolicyGraph.model_validate({"plan_id": "t", "goal": "x", "steps": [survey]})
    swarm = {"area": [corner] * (MAX_POINTS + 1)}
    with pytest.raises(ValueError, match="at most 10000 items"):
        PolicyGraph.model_validate(
            {"plan_id": "t", "goal": "x", "swarm": swarm, "steps": [{"id": "r", "action": "rtl"}]}
        )


# ---- numbers as YAML 1.2 writes them ----

FLY = HEAD + "  - {id: b, action: fly_to, depends_on: [s0], args: {north_m: NORTH, east_m: 0, alt_m: 10}}\n"


@pytest.mark.parametrize(
    ("written", "why"),
    [
        ("1:30", "base-60 numbers are not read, YAML 1.1 would make it 90; write it in decimal"),
        ("-1:30", "base-60 numbers are not read, YAML 1.1 would make it -90; write it in decimal"),
        ("1:30.5", "base-60 numbers are not read, YAML 1.1 would make it 90.5; write it in decimal"),
        ("0x1F", "hexadecimal, octal, binary and leading-zero numbers are not read; write it in decimal, no leading 0"),
        ("012", "hexadecimal, octal, binary and leading-zero numbers are not read; write it in decimal, no leading 0"),
        (
            "0b101",
            "hexadecimal, octal, binary and leading-zero numbers are not read; write it in decimal, no leading 0",
        ),
        ("1_000", "digits grouped with _ are not read; write it without the _"),
        ('"21.4134"', "it is quoted; write it without quotes"),
    ],
)
def test_yaml_1_1_numbers_are_not_silently_numbers(written: str, why: str) -> None:
    """Hostile: PyYAML reads 1:30 as 90 (a waypoint silently 90 m north), 0x1F as 31, 012 as 10 and 1_000 as
    1000; each is refused where the number is, saying what was written and why it is not a number."""
    col = FLY.splitlines()[4].index("north_m: ") + len("north_m: ") + 1
    shown = written.strip('"')
    assert problems(FLY.replace("NORTH", written)) == [
        f"m.yaml:5:{col}: step 'b' args north_m: expected a number or a ${{...}} expression, got {shown!r} "
        f"(text, not a number: {why})"
    ]


def test_exponents_are_numbers_and_an_overflow_is_refused() -> None:
    plan = load_mission(FLY.replace("NORTH", "1.0e2"))
    assert plan.steps[1].args.north_m == 100.0  # type: ignore[union-attr]
    data, _ = load_document("a: 1e3\nb: -2.5E-1\nc: .inf\nd: 7\n", "x.yaml")
    assert data == {"a": 1000.0, "b": -0.25, "c": float("inf"), "d": 7}
    assert problems(FLY.replace("NORTH", "1e400")) == [
        f"m.yaml:5:{FLY.splitlines()[4].index('north_m: ') + 10}: 1e400 is out of range for a number "
        "(beyond ±1.8e308); write a smaller number"
    ]


def test_text_that_looks_like_a_yaml_1_1_number_stays_text_where_text_goes() -> None:
    """A description of 12:30 was the integer 750 to PyYAML (and refused as not text); it is the text written."""
    text = (
        HEAD.replace("action: takeoff}", "action: takeoff, description: 12:30}")
        + "  - {id: n, action: rtl, description: 0x1F}\n"
    )
    plan = load_mission(text)
    assert [s.description for s in plan.steps] == ["12:30", "0x1F"]


# ---- schema errors name what was written ----


def test_a_misspelt_circle_field_is_named_with_no_union_noise() -> None:
    text = "plan_id: g\ngoal: x\nlimits:\n  geofence: {center: {lat: 21.4, lon: 39.9}, radius: 100}\n" + STEPS
    col = text.splitlines()[3].index("radius:") + 1
    assert problems(text) == [f"m.yaml:4:{col}: unknown field 'radius' in limits geofence (did you mean 'radius_m'?)"]


def test_failsafe_keys_are_checked_against_the_failsafes() -> None:
    text = "plan_id: g\ngoal: x\nlimits:\n  failsafe_actions: {gps_loss: land, link: hold}\n" + STEPS
    assert problems(text) == [
        "m.yaml:4:22: unknown key 'gps_loss' in limits failsafe_actions (one of battery, link, wind, gps, flight_time)"
    ]


@pytest.mark.parametrize(
    "written",
    [
        "limits: {geofence: {polygon: [{lat: 21.41, lon: 39.89}, {lat: 21.42, lon: 39.90}]}}",
        "limits: {geofence: {center: [21.41, 39.89], radius_m: 100}}",
        "limits: {geofence: [{lat: 21.41, lon: 39.89}, {lat: 21.42}, {lat: 21.43, lon: 39.9}]}",
        "limits: {geofence: 100}",
        "limits: {failsafe_actions: [gps, land]}",
        "swarm: [1, 2]",
        "steps: [{id: s, action: survey, args: {polygon: {lat: 1, lon: 2}, altitude_m: 20}}]",
        "steps: [{id: s, action: survey, args: {polygon: 5, altitude_m: 20}}]",
        "steps: [{id: n, action: notify, args: {to: {a: 1}, subject: s, body: b}}]",
        "steps: [{id: o, action: orbit, args: {center: [1, 2], radius_m: 10}}]",
    ],
)
def test_no_message_names_a_union_member(written: str) -> None:
    """Hostile: values of the wrong shape wherever the schema has a union; pydantic's member names (Circle,
    list[LatLon], constrained-str, str) are not in the file and must not be in a message, nor one member's
    complaint that a mapping is not a list."""
    found = problems(f"plan_id: g\ngoal: x\n{written}\n" + ("" if written.startswith("steps") else STEPS))
    assert found
    for message in found:
        for leak in ("Circle", "list[", "LatLon", "constrained", " str:", "valid list", "valid string"):
            assert leak not in message, message


def test_a_value_no_member_fits_is_told_every_shape_it_may_take() -> None:
    text = "plan_id: g\ngoal: x\nsteps: [{id: s, action: survey, args: {polygon: {lat: 1, lon: 2}, altitude_m: 20}}]\n"
    [message] = problems(text)
    assert message.endswith(
        "step 's' args polygon: expected a list of mappings (lat, lon) or a ${...} expression, got {'lat': 1, 'lon': 2}"
    )
