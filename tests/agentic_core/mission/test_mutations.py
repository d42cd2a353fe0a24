"""Mutation property test: whatever is done to a valid mission, loading it gives a PolicyGraph or a MissionError
whose every problem has a position in the file and a message; never another exception.

The missions mutated are the shipped ones and the valid corpus. Mutations of the parsed document (delete a key,
change a value's type, rename a key, duplicate a step, alter depends_on, replace an expression with random text)
are dumped back to YAML; YAML syntax garbage is inserted into the text. ``MISSION_FUZZ_EXAMPLES=5000`` runs a
longer search locally.
"""

import copy
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from agentic_core.mission import Environment, MissionError, PolicyGraph, compile_mission, load_mission

HERE = Path(__file__).resolve().parent
SOURCES = sorted([*(HERE.parents[2] / "missions").glob("*.yaml"), *(HERE / "corpus" / "valid").glob("*.yaml")])
TEXTS = [path.read_text(encoding="utf-8") for path in SOURCES]
DOCUMENTS = [yaml.safe_load(text) for text in TEXTS]
EXPRESSION_KEYS = {"preconditions", "condition", "until", "if", "when"}
STEP_LISTS = {"steps", "then", "else"}
FIELD_NAMES = [
    "plan_id",
    "goal",
    "params",
    "limits",
    "steps",
    "triggers",
    "dependencies",
    "id",
    "action",
    "args",
    "depends_on",
    "preconditions",
    "on_fail",
    "tool",
    "if",
    "then",
    "else",
    "until",
    "condition",
    "lat",
    "lon",
    "alt_m",
    "target_id",
    "north_m",
    "geofence",
    "max_altitude_m",
]
EXAMPLES = int(os.environ.get("MISSION_FUZZ_EXAMPLES", "200"))

Path_ = tuple[str | int, ...]
Draw = Callable[[st.SearchStrategy[Any]], Any]  # st.DrawFn, or DataObject.draw

text_chars = st.characters(blacklist_categories=("Cs", "Cc"))
values = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(text_chars, max_size=20),
    st.lists(st.one_of(st.integers(), st.text(text_chars, max_size=5)), max_size=3),
    st.dictionaries(st.text(text_chars, max_size=6), st.integers(), max_size=3),
)
expression_text = st.one_of(
    st.text(text_chars, max_size=30),
    st.text(alphabet="abxyz_.()[]{}'\"+-*/<>=!%$ 0123456789,:#&|~^@", max_size=30),
    st.text(alphabet="abxyz_.()[]'\"+-*<>= 0123456789", max_size=20).map(lambda s: "${" + s + "}"),
    st.sampled_from(
        ["${", "}", "${}", "$${", "${a}${", "__import__('os')", "params.", "steps..x", "1 if", "lambda: 1"]
    ),
)
garbage = st.one_of(
    st.text(alphabet=":-[]{}&*!|>'\"#%@`,? \n\t\\", min_size=1, max_size=8),
    st.sampled_from(["\n  - ", ": :", "&a ", "*a", "!!binary ", "!!python/object:os.system ", "\t", "---\n", "? "]),
    st.text(text_chars, min_size=1, max_size=8),
)


def paths(node: Any, base: Path_ = ()) -> list[Path_]:
    """Every path below ``node`` (mapping keys and list items), parents before children."""
    found: list[Path_] = []
    items: list[tuple[str | int, Any]] = []
    if isinstance(node, dict):
        items = list(node.items())
    elif isinstance(node, list):
        items = list(enumerate(node))
    for key, child in items:
        found.append((*base, key))
        found.extend(paths(child, (*base, key)))
    return found


def get(node: Any, path: Path_) -> Any:
    for part in path:
        node = node[part]
    return node


def set_(node: Any, path: Path_, value: Any) -> None:
    get(node, path[:-1])[path[-1]] = value


def step_paths(doc: Any) -> list[Path_]:
    return [p for p in paths(doc) if isinstance(get(doc, p), dict) and len(p) >= 2 and p[-2] in STEP_LISTS]


def expression_paths(doc: Any) -> list[Path_]:
    found = []
    for p in paths(doc):
        value = get(doc, p)
        if isinstance(value, str) and ("${" in value or any(part in EXPRESSION_KEYS for part in p[-2:])):
            found.append(p)
    return found


def step_ids(doc: Any) -> list[str]:
    return [str(get(doc, p).get("id")) for p in step_paths(doc)]


# --- mutations of the parsed document; each returns False when it found nothing to act on ---
def delete_key(doc: Any, draw: Draw) -> bool:
    keys = [p for p in paths(doc) if isinstance(get(doc, p[:-1]), dict)]
    if not keys:
        return False
    path = draw(st.sampled_from(keys))
    del get(doc, path[:-1])[path[-1]]
    return True


def change_type(doc: Any, draw: Draw) -> bool:
    candidates = paths(doc)
    if not candidates:
        return False
    set_(doc, draw(st.sampled_from(candidates)), draw(values))
    return True


def rename_key(doc: Any, draw: Draw) -> bool:
    keys = [p for p in paths(doc) if isinstance(get(doc, p[:-1]), dict)]
    if not keys:
        return False
    path = draw(st.sampled_from(keys))
    parent = get(doc, path[:-1])
    new = draw(st.one_of(st.sampled_from(FIELD_NAMES), st.text(text_chars, max_size=12), st.integers(0, 3)))
    parent[new] = parent.pop(path[-1])
    return True


def duplicate_step(doc: Any, draw: Draw) -> bool:
    steps = step_paths(doc)
    if not steps:
        return False
    path = draw(st.sampled_from(steps))
    clone = copy.deepcopy(get(doc, path))
    if draw(st.booleans()):
        clone["id"] = draw(st.sampled_from([*step_ids(doc), "copy_1", "bad id", ""]))
    target = get(doc, path[:-1]) if draw(st.booleans()) else get(doc, draw(st.sampled_from(steps))[:-1])
    if not isinstance(target, list):  # an earlier mutation turned the step list into something else
        return False
    target.insert(draw(st.integers(0, len(target))), clone)
    return True


def alter_depends_on(doc: Any, draw: Draw) -> bool:
    steps = step_paths(doc)
    if not steps:
        return False
    step = get(doc, draw(st.sampled_from(steps)))
    ids = [*step_ids(doc), "nowhere", "", "steps"]
    how = draw(st.sampled_from(["shuffle", "replace", "extend", "drop", "scalar"]))
    current = step.get("depends_on")
    if how == "shuffle" and isinstance(current, list):
        step["depends_on"] = draw(st.permutations(current))
    elif how == "drop":
        step.pop("depends_on", None)
    elif how == "scalar":
        step["depends_on"] = draw(st.sampled_from(ids))
    else:
        new = draw(st.lists(st.sampled_from(ids), max_size=4))
        step["depends_on"] = [*(current if how == "extend" and isinstance(current, list) else []), *new]
    return True


def replace_expression(doc: Any, draw: Draw) -> bool:
    candidates = expression_paths(doc)
    if not candidates:
        return False
    set_(doc, draw(st.sampled_from(candidates)), draw(expression_text))
    return True


MUTATIONS = {
    "delete_key": delete_key,
    "change_type": change_type,
    "rename_key": rename_key,
    "duplicate_step": duplicate_step,
    "alter_depends_on": alter_depends_on,
    "replace_expression": replace_expression,
}


@st.composite
def mutants(draw: st.DrawFn) -> str:
    index = draw(st.integers(0, len(TEXTS) - 1))
    kinds = draw(st.lists(st.sampled_from([*MUTATIONS, "yaml_garbage"]), min_size=1, max_size=3))
    text = TEXTS[index]
    data_kinds = [k for k in kinds if k != "yaml_garbage"]
    if data_kinds:
        doc = copy.deepcopy(DOCUMENTS[index])
        for kind in data_kinds:
            if MUTATIONS[kind](doc, draw):
                event(f"mutation: {kind}")
        text = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
    for _ in range(kinds.count("yaml_garbage")):
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(garbage) + text[at:]
        event("mutation: yaml_garbage")
    return text


def never_dispatch(tool: str, args: dict[str, Any], timeout_s: float | None) -> Any:
    raise AssertionError(f"compiling must not call tools (called {tool})")


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutants())
def test_a_mutated_mission_loads_or_fails_with_positioned_problems(text: str) -> None:
    try:
        plan = load_mission(text, file="mutant.yaml")
    except MissionError as exc:
        event("outcome: MissionError")
        assert exc.problems
        last_line = len(text.splitlines()) + 1
        for problem in exc.problems:
            assert problem.file == "mutant.yaml"
            assert problem.line is not None and 1 <= problem.line <= last_line, problem  # always placed
            assert problem.col is not None and problem.col >= 1, problem
            assert problem.message.strip(), problem
    else:
        event("outcome: PolicyGraph")
        assert isinstance(plan, PolicyGraph)
        compile_mission(plan, Environment(dispatch=never_dispatch))  # what validates must compile


# --- the mutations themselves do what they say ---
def test_the_sources_are_valid_missions() -> None:
    assert len(TEXTS) >= 6
    for path in SOURCES:
        assert isinstance(load_mission(path), PolicyGraph)


def test_path_helpers_find_steps_and_expressions() -> None:
    doc = {
        "steps": [
            {"id": "a", "action": "takeoff", "args": {"altitude_m": "${params.x}"}},
            {"id": "b", "action": "branch", "if": "a.ok", "then": [{"id": "c", "action": "rtl"}]},
        ],
        "triggers": [{"id": "t", "when": "true", "steps": [{"id": "d", "action": "rtl", "preconditions": ["x"]}]}],
    }
    assert step_ids(doc) == ["a", "b", "c", "d"]
    assert expression_paths(doc) == [
        ("steps", 0, "args", "altitude_m"),
        ("steps", 1, "if"),
        ("triggers", 0, "when"),
        ("triggers", 0, "steps", 0, "preconditions", 0),
    ]
    set_(doc, ("steps", 1, "then", 0, "id"), "z")
    assert get(doc, ("steps", 1, "then", 0)) == {"id": "z", "action": "rtl"}


@given(st.data())
@settings(max_examples=30, deadline=None)
def test_each_data_mutation_changes_the_document(data: st.DataObject) -> None:
    kind = data.draw(st.sampled_from(sorted(MUTATIONS)))
    index = data.draw(st.integers(0, len(DOCUMENTS) - 1))
    doc = copy.deepcopy(DOCUMENTS[index])
    acted = MUTATIONS[kind](doc, data.draw)
    if not acted:  # nothing to act on (the minimal mission has no expressions): the document is untouched
        assert kind == "replace_expression" and not expression_paths(doc)
        assert doc == DOCUMENTS[index]
    elif kind in ("delete_key", "duplicate_step"):
        assert doc != DOCUMENTS[index]
