"""Mission validation: the valid and invalid corpora, the ``validate`` and ``schema`` commands, the shipped
missions and their JSON Schema.

Each file of ``corpus/invalid/`` starts with ``# expect: LINE:COL: message-substring`` lines, one per problem
the validator must report for it, and no other. Known defects of the validator are pinned at the end of this
file by tests of the correct behaviour.
"""

import functools
import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import yaml

from agentic_core.cli import main
from agentic_core.mission import (
    ACTIONS,
    Environment,
    MissionError,
    PolicyGraph,
    Problem,
    compile_mission,
    iter_steps,
    load_mission,
    mission_json_schema,
)
from agentic_core.mission.model import Circle, FlyToStep, LandStep, OrbitStep, step_args
from agentic_core.mission.templates import find_templates

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[2]
CORPUS = HERE / "corpus"
VALID = sorted((CORPUS / "valid").glob("*.yaml"))
INVALID = sorted((CORPUS / "invalid").glob("*.yaml"))
SHIPPED = sorted((REPO / "missions").glob("*.yaml"))
CORPUS_TOOLS = ["--tools", str(CORPUS / "tools.py")]  # the corpus calls two tools that are not built in
SCHEMA_FILE = REPO / "missions" / "mission.schema.json"
REGENERATE = "agentic-uav schema mission > missions/mission.schema.json"
EXPECT = re.compile(r"^#\s*expect:\s*(\d+):(\d+):\s*(.*\S)\s*$")
PROBLEM_LINE = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): (?P<message>.+)$")

# One invalid file per kind of mistake; a file that goes missing must fail a test, not shrink the corpus.
INVALID_KINDS = {
    "yaml_syntax_error",
    "duplicate_yaml_key",
    "unknown_action",
    "missing_required_field",
    "wrong_type",
    "unknown_field",
    "fly_to_two_destinations",
    "duplicate_step_id",
    "dangling_depends_on",
    "depends_on_across_lists",
    "dependency_cycle",
    "blocked_by_cycle",
    "unknown_expression_name",
    "expression_syntax_error",
    "bad_template",
    "unknown_param",
    "outside_polygon_geofence",
    "outside_circle_geofence",
    "above_max_altitude",
    "survey_point_outside",
    "geofence_two_points",
    "empty",
    "top_level_list",
    "dependencies_unknown_step",
    "self_dependency",
    "step_without_action",
    "trigger_id_reused",
    "invalid_step_id",
    "no_steps",
}


def never_dispatch(tool: str, args: dict[str, Any], timeout_s: float | None) -> Any:
    raise AssertionError(f"compiling a mission must not call tools (called {tool})")


def expectations(path: Path) -> list[tuple[int, int, str]]:
    """The ``# expect:`` lines of the comment block a corpus file starts with."""
    found = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        match = EXPECT.match(line)
        if match:
            found.append((int(match[1]), int(match[2]), match[3]))
    return found


def problems_of(source: str | Path, **kwargs: Any) -> list[Problem]:
    with pytest.raises(MissionError) as info:
        load_mission(source, **kwargs)
    return list(info.value.problems)


@functools.cache
def schema_validator() -> jsonschema.Draft202012Validator:
    schema = json.loads(SCHEMA_FILE.read_text(encoding="utf-8"))
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


# --- the valid corpus ---
@pytest.mark.parametrize("path", VALID, ids=lambda p: p.stem)
def test_valid_corpus_file_loads_and_compiles(path: Path) -> None:
    plan = load_mission(path)
    assert isinstance(plan, PolicyGraph)
    assert plan.steps
    graph = compile_mission(plan, Environment(dispatch=never_dispatch))
    assert {s.id for s in plan.steps} <= set(graph.get_graph().nodes)


def test_valid_corpus_covers_the_whole_language() -> None:
    plans = [load_mission(path) for path in VALID]
    steps = [site.step for plan in plans for site in iter_steps(plan)]
    assert {s.action for s in steps} == set(ACTIONS)
    fly_to = [s.args for s in steps if isinstance(s, FlyToStep)]
    assert any(a.lat is not None for a in fly_to)
    assert any(a.north_m is not None for a in fly_to)
    assert any(a.target_id is not None for a in fly_to)
    orbits = [s.args for s in steps if isinstance(s, OrbitStep)]
    assert any(a.center is not None for a in orbits) and any(a.target_id is not None for a in orbits)
    lands = [s.args for s in steps if isinstance(s, LandStep)]
    assert any(a.lat is not None for a in lands) and any(a.target_id is not None for a in lands)
    fences = [plan.limits.geofence for plan in plans]
    assert any(isinstance(f, list) for f in fences) and any(isinstance(f, Circle) for f in fences)
    assert any(plan.triggers for plan in plans)
    assert any(plan.dependencies for plan in plans)
    assert {p.type for plan in plans for p in plan.params.values()} == {
        "number",
        "integer",
        "string",
        "boolean",
        "position",
    }
    assert sum(len(find_templates(step_args(s))) for s in steps) >= 20
    assert any(s.preconditions for s in steps)
    branches = [s for s in steps if s.action == "branch"]
    assert any(getattr(b, "else_", None) for b in branches)


# --- the invalid corpus ---
def test_invalid_corpus_has_one_file_per_kind_of_mistake() -> None:
    assert {p.stem for p in INVALID} == INVALID_KINDS
    for path in INVALID:
        assert expectations(path), f"{path.name} has no '# expect: LINE:COL: message' line"


@pytest.mark.parametrize("path", INVALID, ids=lambda p: p.stem)
def test_invalid_corpus_file_reports_exactly_the_expected_problems(path: Path) -> None:
    expected = expectations(path)
    problems = problems_of(path)
    listing = "\n".join(map(str, problems))
    assert len(problems) == len(expected), f"expected {len(expected)} problems, got:\n{listing}"
    unmatched = list(problems)
    for line, col, text in expected:
        hit = next((p for p in unmatched if (p.line, p.col) == (line, col) and text in p.message), None)
        assert hit is not None, f"no problem at {line}:{col} containing {text!r}; got:\n{listing}"
        unmatched.remove(hit)
    for problem in problems:
        assert problem.file == str(path)
        assert str(problem) == f"{path}:{problem.line}:{problem.col}: {problem.message}"
    assert problems == sorted(problems)


@pytest.mark.parametrize("path", INVALID, ids=lambda p: p.stem)
def test_invalid_text_names_the_given_file(path: Path) -> None:
    problems = problems_of(path.read_text(encoding="utf-8"), file="mission.yaml")
    assert {p.file for p in problems} == {"mission.yaml"}
    assert [(p.line, p.col) for p in problems] == sorted((line, col) for line, col, _ in expectations(path))


def test_unreadable_file_is_a_problem_not_a_crash(tmp_path: Path) -> None:
    missing = tmp_path / "nowhere.yaml"
    (problem,) = problems_of(missing)
    assert (problem.file, problem.line, problem.col) == (str(missing), 1, 1)
    assert "cannot read the file" in problem.message


# --- the command line ---
def test_cli_validate_valid_files_prints_one_summary_each(capsys: pytest.CaptureFixture[str]) -> None:
    files = [str(p) for p in [*SHIPPED, *VALID]]
    assert main(["validate", *CORPUS_TOOLS, *files]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    lines = out.splitlines()
    assert len(lines) == len(files)
    for name, line in zip(files, lines, strict=True):
        assert line.startswith(f"{name}: ok: plan ")
    plan = load_mission(VALID[0])
    assert f"{plan.plan_id!r}, {len(plan.steps)} steps" in lines[len(SHIPPED)]


@pytest.mark.parametrize("path", INVALID, ids=lambda p: p.stem)
def test_cli_validate_invalid_file_exits_2_with_file_line_col(path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["validate", *CORPUS_TOOLS, str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    positions = []
    for line in err.splitlines():
        match = PROBLEM_LINE.match(line)
        assert match, line
        assert match["file"] == str(path)
        positions.append((int(match["line"]), int(match["col"])))
    assert positions == sorted((line, col) for line, col, _ in expectations(path))


def test_cli_validate_mixed_files_reports_all_and_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    good, bad, worse = VALID[0], CORPUS / "invalid" / "unknown_action.yaml", CORPUS / "invalid" / "wrong_type.yaml"
    assert main(["validate", *CORPUS_TOOLS, str(bad), str(good), str(worse)]) == 2
    out, err = capsys.readouterr()
    (summary,) = out.splitlines()
    assert summary.startswith(f"{good}: ok: plan ")
    assert len(err.splitlines()) == len(expectations(bad)) + len(expectations(worse))
    assert err.splitlines()[0].startswith(f"{bad}:")
    assert err.splitlines()[-1].startswith(f"{worse}:")


def test_cli_as_a_process() -> None:
    good, bad = VALID[0], CORPUS / "invalid" / "dangling_depends_on.yaml"
    proc = subprocess.run(
        [sys.executable, "-m", "agentic_core", "validate", *CORPUS_TOOLS, str(good), str(bad)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=REPO,
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout.startswith(f"{good}: ok: plan ")
    assert proc.stderr == f"{bad}:10:18: step 'down' depends on unknown step 'clim' (did you mean 'climb'?)\n"
    proc = subprocess.run(
        [sys.executable, "-m", "agentic_core", "validate", *CORPUS_TOOLS, str(good)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=REPO,
    )
    assert (proc.returncode, proc.stderr) == (0, "")


# --- shipped missions and their schema ---
@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_mission_validates_and_compiles(path: Path) -> None:
    plan = load_mission(path)
    compile_mission(plan, Environment(dispatch=never_dispatch))


def test_shipped_missions_exist() -> None:
    assert len(SHIPPED) >= 3


def test_shipped_schema_is_current(capsys: pytest.CaptureFixture[str]) -> None:
    shipped = SCHEMA_FILE.read_text(encoding="utf-8")
    assert shipped == json.dumps(mission_json_schema(), indent=2) + "\n", (
        f"missions/mission.schema.json is out of date with the mission model; regenerate it: {REGENERATE}"
    )
    assert main(["schema", "mission"]) == 0
    assert capsys.readouterr().out == shipped, f"regenerate the shipped schema: {REGENERATE}"


@pytest.mark.parametrize("path", [*SHIPPED, *VALID], ids=lambda p: p.stem)
def test_shipped_schema_accepts_valid_mission(path: Path) -> None:
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    errors = [f"{list(e.absolute_path)}: {e.message}" for e in schema_validator().iter_errors(data)]
    assert errors == []


@pytest.mark.parametrize(
    "name",
    [
        "unknown_action",
        "unknown_field",
        "wrong_type",
        "missing_required_field",
        "invalid_step_id",
        "no_steps",
        "step_without_action",
        "top_level_list",
    ],
)
def test_shipped_schema_rejects_what_it_can_express(name: str) -> None:
    data = yaml.safe_load((CORPUS / "invalid" / f"{name}.yaml").read_text(encoding="utf-8"))
    assert not schema_validator().is_valid(data)


# --- defects found in review, each fixed; the tests state the correct behaviour ---


def mission(steps: str, *, head: str = "") -> str:
    return f"plan_id: P-1\ngoal: test\n{head}steps:\n{steps}"


def test_template_in_polygon_geofence_does_not_crash() -> None:
    text = mission(
        "  - {id: go, action: fly_to, args: {lat: 21.41, lon: 39.89}}\n",
        head="params: {lat0: {default: 21.40}}\nlimits:\n  geofence:\n"
        '    - {lat: "${params.lat0}", lon: 39.88}\n    - {lat: 21.40, lon: 39.90}\n    - {lat: 21.42, lon: 39.90}\n',
    )
    assert load_mission(text).steps[0].id == "go"


def test_template_speed_is_accepted() -> None:
    text = mission(
        '  - {id: go, action: fly_to, args: {north_m: 5, east_m: 5, speed_mps: "${params.speed}"}}\n',
        head="params: {speed: {default: 4}}\n",
    )
    assert load_mission(text).steps[0].id == "go"


def test_recursive_yaml_alias_is_a_problem() -> None:
    problems = problems_of("plan_id: P-1\ngoal: test\nsteps: &s\n  - {id: up, action: takeoff}\n  - *s\n")
    assert problems and all(p.line and p.col and p.message for p in problems)


def test_deeply_nested_yaml_is_a_problem() -> None:
    problems = problems_of("plan_id: P-1\ngoal: test\nsteps: " + "[" * 3000 + "]" * 3000 + "\n")
    assert problems


def test_control_character_is_a_problem(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    text = "plan_id: P-1\ngoal: te\x1fst\nsteps: [{id: up, action: takeoff}]\n"
    (problem,) = problems_of(text)
    assert problem.line == 2 and problem.message
    path = tmp_path / "control.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["validate", *CORPUS_TOOLS, str(path)]) == 2
    assert capsys.readouterr().err.startswith(f"{path}:2:")


def test_file_that_is_not_utf8_is_a_problem(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = tmp_path / "latin1.yaml"
    path.write_bytes(b"plan_id: P-1\ngoal: caf\xe9\nsteps: [{id: up, action: takeoff}]\n")
    (problem,) = problems_of(path)
    assert problem.file == str(path) and problem.line and problem.message
    assert main(["validate", *CORPUS_TOOLS, str(path)]) == 2
    assert capsys.readouterr().err.startswith(f"{path}:")


def test_unknown_top_level_field_message_is_complete() -> None:
    (problem,) = problems_of("plan_idd: P-1\nplan_id: P-1\ngoal: test\nsteps: [{id: up, action: takeoff}]\n")
    assert (problem.line, problem.col) == (1, 1)
    assert "'plan_idd'" in problem.message
    assert not problem.message.rstrip().endswith(" in")


def test_wrong_type_for_a_number_or_template_is_one_problem() -> None:
    problems = problems_of(mission("  - {id: up, action: takeoff, args: {altitude_m: high}}\n"))
    assert len(problems) == 1
    assert "altitude_m" in problems[0].message


def test_missing_field_message_names_the_field_once() -> None:
    problems = problems_of("plan_id: P-1\nsteps: [{id: h, action: hover, args: {}}]\n")
    assert [m for p in problems for m in ("goal", "duration_s") if p.message.count(m) == 1] == ["goal", "duration_s"]


def test_bad_parameter_name_message() -> None:
    (problem,) = problems_of(mission("  - {id: up, action: takeoff}\n", head='params: {"bad key": {default: 1}}\n'))
    assert "bad key" in problem.message
    assert "[key]" not in problem.message


def test_yaml_syntax_error_separates_context_from_problem() -> None:
    (problem,) = problems_of(CORPUS / "invalid" / "yaml_syntax_error.yaml")
    assert "YAML syntax error" in problem.message
    assert "mapping expected" not in problem.message


def test_expression_syntax_error_at_the_end_is_not_column_0() -> None:
    (problem,) = problems_of(mission('  - {id: w, action: wait_until, condition: "vehicle.battery_pct >"}\n'))
    assert "column 0" not in problem.message


def test_unknown_dependency_suggestion_is_not_the_step_itself() -> None:
    text = mission(
        "  - {id: step_1, action: takeoff}\n  - {id: step_2, action: rtl, depends_on: [step_0]}\n",
    )
    (problem,) = problems_of(text)
    assert "unknown step 'step_0'" in problem.message
    assert "did you mean 'step_2'" not in problem.message


def test_unknown_dependency_suggestion_finds_the_typo() -> None:
    text = mission("  - {id: climb, action: takeoff}\n  - {id: land_now, action: land, depends_on: [clmb]}\n")
    (problem,) = problems_of(text)
    assert (problem.line, problem.col) == (5, 47)
    assert "did you mean 'climb'?" in problem.message


def test_params_inside_a_string_literal_is_not_a_parameter() -> None:
    text = mission("  - {id: w, action: wait_until, condition: \"vehicle.mode != 'params.x'\"}\n")
    assert load_mission(text).steps[0].id == "w"


def test_error_location_when_a_step_has_a_key_named_like_its_action() -> None:
    text = mission("  - id: a\n    action: hover\n    hover: {duration_s: 1}\n    args:\n      duration_s: soon\n")
    problems = problems_of(text)
    assert any(p.line == 6 and "unknown field 'hover'" in p.message for p in problems)
    assert any(p.line == 8 and "duration_s" in p.message for p in problems), "\n".join(map(str, problems))


def test_duplicate_key_does_not_hide_other_problems() -> None:
    text = mission(
        "  - id: a\n    action: hover\n    args:\n      duration_s: 1\n      duration_s: 2\n"
        "  - id: b\n    action: takeof\n"
    )
    messages = [p.message for p in problems_of(text)]
    assert any("duplicate key 'duration_s'" in m for m in messages)
    assert any("unknown action 'takeof'" in m for m in messages)


NONSENSE = {
    "latitude beyond 90": ("  - {id: go, action: fly_to, args: {lat: 2141.3, lon: 39.89}}\n", "lat"),
    "latitude not a number": ("  - {id: go, action: fly_to, args: {lat: .nan, lon: 39.89}}\n", "lat"),
    "negative hover": ("  - {id: h, action: hover, args: {duration_s: -5}}\n", "duration_s"),
    "negative takeoff altitude": ("  - {id: up, action: takeoff, args: {altitude_m: -10}}\n", "altitude_m"),
    "negative orbit radius": (
        "  - {id: o, action: orbit, args: {target_id: P-1, radius_m: -20}}\n",
        "radius_m",
    ),
    "zero survey spacing": (
        "  - {id: s, action: survey, args: {altitude_m: 20, spacing_m: 0,"
        " polygon: [{lat: 1, lon: 1}, {lat: 1, lon: 2}, {lat: 2, lon: 2}]}}\n",
        "spacing_m",
    ),
}


@pytest.mark.parametrize("case", NONSENSE)
def test_nonsensical_values_are_rejected_at_load_time(case: str) -> None:
    steps, field = NONSENSE[case]
    problems = problems_of(mission(steps))
    assert any(field in p.message for p in problems), "\n".join(map(str, problems))


def test_parameter_default_must_match_its_type() -> None:
    text = mission(
        "  - {id: up, action: takeoff}\n", head='params: {rounds: {type: integer, default: "many", minimum: 1}}\n'
    )
    (problem,) = problems_of(text)
    assert problem.line == 3 and "rounds" in problem.message


SCHEMA_DISAGREEMENTS = {
    "if_ and else_ spelled as the Python field names": mission(
        '  - {id: b, action: branch, if_: "true", then: [{id: up, action: takeoff}], else_: [{id: x, action: rtl}]}\n'
    ),
    "numbers and booleans written as strings": mission(
        '  - {id: up, action: takeoff, args: {altitude_m: "30"}, max_retries: "2", approval: "true"}\n'
    ),
    "a geofence polygon of two points": mission(
        "  - {id: up, action: takeoff}\n", head="limits: {geofence: [{lat: 1, lon: 1}, {lat: 1, lon: 2}]}\n"
    ),
    "a negative fly_to speed": mission("  - {id: go, action: fly_to, args: {north_m: 1, east_m: 1, speed_mps: -1}}\n"),
}


@pytest.mark.parametrize("case", SCHEMA_DISAGREEMENTS)
def test_schema_and_validator_agree(case: str) -> None:
    text = SCHEMA_DISAGREEMENTS[case]
    try:
        load_mission(text)
        validator_accepts = True
    except MissionError:
        validator_accepts = False
    assert schema_validator().is_valid(yaml.safe_load(text)) == validator_accepts


def test_schema_uses_only_json_schema_keywords() -> None:
    pydantic_only = {"gt", "ge", "lt", "le", "multiple_of", "min_length", "max_length"}
    found: list[str] = []

    def walk(node: Any, where: str) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                if key in pydantic_only and not where.endswith("properties"):
                    found.append(f"{where}.{key}")
                walk(value, f"{where}.{key}")
        elif isinstance(node, list):
            for i, item in enumerate(node):
                walk(item, f"{where}[{i}]")

    walk(mission_json_schema(), "$")
    assert found == []
