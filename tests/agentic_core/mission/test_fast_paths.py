"""The shortcuts loading and validation take for speed give the answers the long way gives.

Loading keeps the text, not the composed YAML tree, and composes it again only when a problem needs a position;
the cyclic garbage collector is paused while a document is read; plain scalars are resolved once per text;
expressions know their names and fields from the one walk that checks them; the dependency graph is checked for
cycles without networkx, and what a step may read is kept as bits of its ancestors. Each test pins what the
shortcut must not change.
"""

import gc
from collections.abc import Iterator

import pytest

from agentic_core.mission import MissionError, load_mission
from agentic_core.mission.expressions import Expression
from agentic_core.mission.source import load_document
from agentic_core.mission.templates import find_templates


def messages(text: str) -> list[str]:
    with pytest.raises(MissionError) as err:
        load_mission(text, file="m.yaml")
    return [str(problem) for problem in err.value.problems]


# ---- positions from a tree composed again ----

MERGED = """\
plan_id: P
goal: g
defaults: &d
  action: hover
  args: {duration_s: -1}
steps:
  - id: up
    action: takeoff
  - <<: *d
    id: wait
    depends_on: [up]
"""


def test_the_source_map_composes_the_tree_only_when_a_position_is_asked_for() -> None:
    data, smap = load_document("plan_id: P\ngoal: g\nsteps:\n  - {id: up, action: takeoff}\n", "m.yaml")
    assert data["steps"][0]["id"] == "up"
    assert smap.root is None  # a valid mission never pays for positions
    assert smap.at(("steps", 0, "action")) == (4, 22)
    assert smap.at(("steps", 0, "action"), key=True) == (4, 14)
    assert smap.at(("steps", 5, "nowhere")) == (4, 3)  # a missing part: its nearest ancestor (the list)
    assert smap.root is not None


def test_a_merged_field_is_reported_where_the_anchor_wrote_it() -> None:
    assert messages(MERGED) == [
        "m.yaml:3:1: unknown field 'defaults' in the mission (known: plan_id, goal, params, limits, steps, "
        "triggers, dependencies, on_abort, scopes, knowledge, allow_tools, swarm)",
        "m.yaml:5:22: step 'wait' args duration_s: Input should be greater than 0",
    ]


def test_a_key_given_three_times_names_the_one_before_it() -> None:
    assert messages("plan_id: P\ngoal: g\nsteps: [{id: a, action: takeoff}]\ngoal: h\ngoal: i\n") == [
        "m.yaml:4:1: duplicate key 'goal' (first at line 2); the last wins",
        "m.yaml:5:1: duplicate key 'goal' (first at line 4); the last wins",
    ]


# ---- the garbage collector and the resolver ----


@pytest.fixture
def collector_off() -> Iterator[None]:
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


def test_loading_leaves_an_enabled_collector_enabled() -> None:
    assert gc.isenabled()
    load_document("a: [1, 2, {b: c}]\n", "m.yaml")
    assert gc.isenabled()
    with pytest.raises(MissionError):
        load_document("a: [1, 2\n", "m.yaml")  # a syntax error half-way through
    with pytest.raises(MissionError):
        load_document("a: " + "[" * 3000 + "]" * 3000 + "\n", "m.yaml")  # nested too deeply
    assert gc.isenabled()


@pytest.mark.usefixtures("collector_off")
def test_loading_leaves_a_disabled_collector_disabled() -> None:
    load_document("a: 1\n", "m.yaml")
    assert not gc.isenabled()


def test_quoted_and_plain_scalars_of_the_same_text_keep_their_types() -> None:
    data, _ = load_document("a: '30'\nb: 30\nc: \"30\"\nd: 30\ne: 'true'\nf: true\ng: ~\nh: '~'\ni: 30\n", "m.yaml")
    assert data == {"a": "30", "b": 30, "c": "30", "d": 30, "e": "true", "f": True, "g": None, "h": "~", "i": 30}


# ---- expressions and templates ----


def test_names_and_fields_are_those_the_expression_reads() -> None:
    expr = Expression.parse("count(world.objects, class_=params.cls) > steps.scan.persons and scan.ok or x")
    assert expr.root_names == frozenset({"world", "params", "steps", "scan", "x"})
    assert expr.fields_of("params") == frozenset({"cls"})
    assert expr.fields_of("steps") == frozenset({"scan"})
    assert expr.fields_of("world") == frozenset({"objects"})
    assert expr.fields_of("x") == frozenset()
    assert expr.fields_of("nowhere") == frozenset()


def test_template_paths_through_tuples_and_odd_keys() -> None:
    value = {"a": (1, "${x}"), 3: "${y}", "n": None, "f": 1.5, "t": True, "s": "plain", "q": {"it's": "${z}"}}
    assert [(path, expr.source) for path, expr in find_templates(value)] == [
        ("a[1]", "x"),
        ("[3]", "y"),
        ('q["it\'s"]', "z"),
    ]


# ---- dependencies ----

CHAIN = """\
plan_id: P
goal: g
steps:
  - {id: a, action: takeoff}
  - {id: b, action: hover, args: {duration_s: 1}, depends_on: [a]}
  - {id: c, action: hover, args: {duration_s: 1}, depends_on: [b]}
  - {id: d, action: hover, args: {duration_s: 1}, depends_on: [a]}
  - {id: e, action: wait_until, condition: "a.ok and c.ok and steps.d.ok", depends_on: [c]}
"""


def test_a_step_may_read_what_it_waits_for_through_a_chain_and_nothing_else() -> None:
    assert messages(CHAIN) == [
        "m.yaml:8:44: 'a.ok and c.ok and steps.d.ok' reads step 'd', which 'e' does not wait for: it may not "
        "have run yet; add 'd' to depends_on"
    ]


def test_diamonds_and_the_papers_dependencies_are_not_cycles() -> None:
    plan = load_mission(
        "plan_id: P\ngoal: g\nsteps:\n  - {id: a, action: takeoff}\n  - {id: b, action: rtl, depends_on: [a]}\n"
        "  - {id: c, action: rtl}\n  - {id: d, action: land, depends_on: [b]}\n"
        "dependencies: {c: [a], d: [c, a]}\n"
    )
    assert [s.id for s in plan.steps] == ["a", "b", "c", "d"]


def test_a_cycle_made_of_both_kinds_of_dependency_is_found() -> None:
    found = messages(
        "plan_id: P\ngoal: g\nsteps:\n  - {id: a, action: takeoff}\n  - {id: b, action: rtl, depends_on: [a]}\n"
        "  - {id: c, action: rtl, depends_on: [b]}\n  - {id: d, action: land, depends_on: [c]}\n"
        "dependencies: {a: [c]}\n"
    )
    assert found == [
        "m.yaml:4:5: dependency cycle: a -> b -> c -> a (each must finish before the next, so none can start)",
        "m.yaml:7:10: step 'd' can never run: it waits (through depends_on) for a dependency cycle",
    ]
