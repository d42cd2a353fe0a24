"""Hostile inputs meet bounds: each is refused fast with exit 2 and its place, never a hang, an exhausted memory
or a traceback. The timeout markers are the "fast": a regression hangs and fails, with no wall-clock assertion."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from agentic_core.cli import main
from agentic_core.contracts.input_files import InputFileError, check_input_file, max_input_bytes
from agentic_core.contracts.json_depth import JsonTooDeep, depth_of, loads
from agentic_core.mission import MissionError, load_mission
from evaluation.stats.columns import MAX_GROUPS
from evaluation.stats.dataset import load_dataset
from evaluation.stats.errors import InputError as StatsInputError
from flight.sim.scene_file import SceneFileError, load_scene
from tools.errors import ToolDefinitionError
from tools.http_endpoint import load_http_tools

LAUGHS = "".join(
    f"{chr(97 + i)}: &{chr(97 + i)} [{','.join([f'*{chr(96 + i)}'] * 9)}]\n" if i else 'a: &a ["lol","lol","lol"]\n'
    for i in range(9)
)


def test_the_billion_laughs_document_is_small() -> None:
    assert len(LAUGHS.encode()) <= 340 and LAUGHS.count("*") > 60


@pytest.mark.timeout(20)
def test_billion_laughs_mission_fails_fast_with_its_place(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "laughs.yaml"
    path.write_text(LAUGHS)
    with pytest.raises(MissionError) as caught:
        load_mission(path)
    (problem,) = caught.value.problems
    assert problem.file == str(path) and problem.line is not None and problem.col is not None
    assert "aliases repeat more than" in problem.message
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:{problem.line}:{problem.col}:" in err and "Traceback" not in err


@pytest.mark.timeout(20)
def test_billion_laughs_through_merge_keys_fails_fast(tmp_path: Path) -> None:
    lines = ["a0: &a0 {x0: 1, x1: 2, x2: 3, x3: 4}"]
    lines += [f"a{i}: &a{i} {{<<: [{', '.join([f'*a{i - 1}'] * 9)}], k{i}: 1}}" for i in range(1, 12)]
    with pytest.raises(MissionError, match="aliases repeat"):
        load_mission("\n".join(lines) + "\n", file="merge.yaml")


def test_ordinary_aliases_still_load() -> None:
    text = (
        "plan_id: p\ngoal: g\nsteps:\n  - {id: up, action: takeoff, args: &d {altitude_m: 20}}\n"
        "  - {id: again, action: takeoff, args: *d, depends_on: [up]}\n"
        "  - {id: down, action: land, depends_on: [again]}\n"
    )
    plan = load_mission(text, file="ok.yaml")
    assert [s.id for s in plan.steps] == ["up", "again", "down"]


@pytest.mark.timeout(20)
@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_a_fifo_or_device_is_refused_at_once_everywhere(tmp_path: Path, kind: str) -> None:
    if kind == "fifo":
        target = tmp_path / "input.yaml"
        os.mkfifo(target)  # nobody ever writes to it: reading would block forever
    else:
        target = Path("/dev/zero")  # reading would never end
    for load, error in (
        (load_mission, MissionError),
        (load_scene, SceneFileError),
        (load_http_tools, ToolDefinitionError),
        (load_dataset, StatsInputError),
    ):
        with pytest.raises(error, match="not a regular file") as caught:
            load(target)
        assert str(target) in str(caught.value)
    assert main(["validate", str(target)]) == 2


@pytest.mark.timeout(20)
def test_a_file_over_the_size_limit_is_refused_and_the_limit_can_be_raised(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "big.yaml"
    with path.open("wb") as out:
        out.truncate(3 * 2**20)  # 3 MB of NUL bytes, sparse: never parsed if the limit holds
    monkeypatch.setenv("AGENTIC_UAV_MAX_INPUT_MB", "1")
    with pytest.raises(MissionError, match=r"over the 1 MB limit; raise it with AGENTIC_UAV_MAX_INPUT_MB"):
        load_mission(path)
    monkeypatch.setenv("AGENTIC_UAV_MAX_INPUT_MB", "4")
    assert check_input_file(path, "mission") == 3 * 2**20
    monkeypatch.setenv("AGENTIC_UAV_MAX_INPUT_MB", "lots")
    with pytest.raises(InputFileError, match="not a number"):
        max_input_bytes()


@pytest.mark.timeout(20)
def test_twelve_mutually_dependent_steps_report_one_cycle_fast() -> None:
    ids = [f"s{i}" for i in range(12)]
    steps = "".join(f"  - {{id: {s}, action: rtl, depends_on: [{', '.join(o for o in ids if o != s)}]}}\n" for s in ids)
    steps += "  - {id: after, action: land, depends_on: [s3]}\n"
    with pytest.raises(MissionError) as caught:
        load_mission(f"plan_id: p\ngoal: g\nsteps:\n{steps}", file="knot.yaml")
    messages = [p.message for p in caught.value.problems]
    cycles = [m for m in messages if m.startswith("dependency cycle")]
    assert len(cycles) == 1 and "12 steps wait for each other" in cycles[0]
    assert any("'after' can never run" in m for m in messages)


@pytest.mark.timeout(20)
def test_two_separate_knots_are_two_cycles() -> None:
    steps = (
        "  - {id: a, action: rtl, depends_on: [b]}\n"
        "  - {id: b, action: rtl, depends_on: [a]}\n"
        "  - {id: c, action: rtl, depends_on: [d]}\n"
        "  - {id: d, action: rtl, depends_on: [c]}\n"
    )
    with pytest.raises(MissionError) as caught:
        load_mission(f"plan_id: p\ngoal: g\nsteps:\n{steps}", file="two.yaml")
    cycles = [p for p in caught.value.problems if p.message.startswith("dependency cycle")]
    assert [c.message.split(" (")[0] for c in cycles] == [
        "dependency cycle: a -> b -> a",
        "dependency cycle: c -> d -> c",
    ]
    assert [c.line for c in cycles] == [4, 6]


@pytest.mark.timeout(60)
def test_eval_stats_caps_the_groups(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "many.csv"
    rows = [f"g{i},{i % 7}.5" for i in range(1000) for _ in range(2)]
    path.write_text("group,latency_s\n" + "\n".join(rows) + "\n")
    with pytest.raises(StatsInputError, match=f"more than {MAX_GROUPS} groups") as caught:
        load_dataset(path, group="group")
    assert f":{MAX_GROUPS * 2 + 2}" in str(caught.value)  # the line of the first group over the cap
    assert main(["eval", "stats", str(path), "--group", "group"]) == 2
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.timeout(20)
def test_deeply_nested_json_is_a_clear_error(tmp_path: Path) -> None:
    deep = "[" * 100_000 + "]" * 100_000
    with pytest.raises(JsonTooDeep, match="nested more than 100 levels"):
        loads(deep)
    with pytest.raises(JsonTooDeep):
        loads('{"a":' * 150 + "1" + "}" * 150)  # under Python's recursion limit, over ours
    assert depth_of(loads('{"a": [[1]]}')) == 3
    results = tmp_path / "results.json"
    results.write_text(deep)
    with pytest.raises(StatsInputError, match="nested more than"):
        load_dataset(results)
    lines = tmp_path / "results.jsonl"
    lines.write_text('{"group": "a", "x": 1}\n' + '{"group":' * 5000 + "1" + "}" * 5000 + "\n")
    with pytest.raises(StatsInputError, match=r"results.jsonl:2: JSON nested more than"):
        load_dataset(lines)
