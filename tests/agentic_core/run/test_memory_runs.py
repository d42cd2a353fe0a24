"""The Done-when of issue 20: a second run of the patrol mission over the same scene uses what the first recorded,
visibly in its trace; and a run without ``--memory`` has no memory events at all."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from agentic_core.contracts.memory import Provenance
from agentic_core.memory.cli import main as memory_main
from agentic_core.perception.world_model import WorldModel
from agentic_core.reasoning.rules import RuleReasoner
from agentic_core.run.run_memory import RunMemory, with_memory
from agentic_core.run.runner import MissionRun, RunSettings

REPO = Path(__file__).resolve().parents[3]
PATROL = REPO / "missions" / "hajj_patrol.yaml"
NORMAL = REPO / "tests" / "agentic_core" / "run" / "scenes" / "small_normal.yaml"


def fly(tmp_path: Path, memory: Path | None, seed: int) -> list[dict[str, Any]]:
    settings = RunSettings(mission=PATROL, scene=NORMAL, runs_dir=tmp_path / "runs", params={"rounds": "1"},
                           camera_hz=2.0, seed=seed, memory=memory, gcs="none")  # fmt: skip
    result = MissionRun(settings).execute()
    assert result.summary.outcome == "completed"
    lines = (result.run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()
    return [json.loads(line) for line in lines]


def of(records: list[dict[str, Any]], kind: str, **match: Any) -> list[dict[str, Any]]:
    return [r for r in records if r["kind"] == kind and all(r.get(k) == v for k, v in match.items())]


@pytest.mark.slow
def test_the_second_patrol_recalls_and_cites_what_the_first_recorded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    memory = tmp_path / "fleet" / "memory.db"
    first = fly(tmp_path, memory, seed=1)
    known = of(first, "memory", event="recalled")[0]
    assert (
        known["memories"] == [] and known["runs"] == [] and known["search"]
    )  # nothing known yet; says how it searches
    recorded = of(first, "memory", event="recorded")[0]["memories"]
    logged = of(first, "tool", name="incidents.log", status="ok")
    assert len(recorded) == len(logged) == 2 and all(k.startswith("incident/") for k in recorded)

    second = fly(tmp_path, memory, seed=2)
    recalled = of(second, "memory", event="recalled")[0]
    assert sorted(recalled["memories"]) == sorted(recorded)
    assert len(recalled["runs"]) == 1
    looks = of(second, "decision", why="analyze_scene")
    cited = [d for d in looks if any(f"[memory {k}]" in d["assessment"]["rationale"] for k in recorded)]
    assert len(cited) == len(looks) == 2, [d["assessment"]["rationale"] for d in looks]
    west = next(d for d in cited if "west" in d["focus"])
    assert "west gate" in west["assessment"]["rationale"]  # the memory of the west gate, not the east one's
    assert "east gate:" not in west["assessment"]["rationale"]

    # the chain: the second run's decision cites the first run's incident, which came from its trace
    decisions = [k for k in of(second, "memory", event="recorded")[0]["memories"] if k.startswith("decision/")]
    assert decisions
    capsys.readouterr()
    assert memory_main(["--memory", str(memory), "why", decisions[0]]) == 0
    chain = capsys.readouterr().out
    assert "cites:" in chain and "incidents.log" not in chain and "step patrol/log_" in chain
    assert recalled["runs"][0] in chain


def test_without_memory_the_run_keeps_its_reasoner_and_opens_nothing(tmp_path: Path) -> None:
    """A run without ``--memory`` is the run of before: the same reasoner object, no memory, no file."""
    settings = RunSettings(mission=PATROL, scene=NORMAL, runs_dir=tmp_path / "runs")
    reasoner = RuleReasoner()
    run = SimpleNamespace(settings=settings, run_id="r", plan=None, scene=None, view=dict, _target=lambda o: None)
    assert with_memory(run, reasoner) == (None, reasoner)
    assert list(tmp_path.iterdir()) == []
    remembering = settings.model_copy(update={"memory": tmp_path / "m.db"})
    with_settings = SimpleNamespace(
        **{**vars(run), "settings": remembering, "plan": SimpleNamespace(plan_id="p", knowledge=[])}
    )
    memory, wrapped = with_memory(with_settings, reasoner)
    assert memory is not None and wrapped is not reasoner and wrapped.name == "rules"
    memory.fleet.close()


def test_the_context_port_recalls_earlier_runs_answers_near_the_aircraft_not_this_runs(tmp_path: Path) -> None:
    memory = RunMemory(tmp_path / "m.db", "R2", view=dict, locate=lambda o: None, mission="p", scene=None)
    lat, lon = 21.4133, 39.8933
    memory.fleet.remember("approval", "R1:5", "operator declined: land near P-9?", lat=lat, lon=lon,
                          provenance=Provenance(run_id="R1", verdict="declined"))  # fmt: skip
    memory.fleet.remember("incident", "R2:3", "this run's own", lat=lat, lon=lon, provenance=Provenance(run_id="R2"))
    memory.fleet.remember("incident", "R1:9", "a kilometre away", lat=21.4223, lon=39.8933,
                          provenance=Provenance(run_id="R1"))  # fmt: skip
    ego = {"north": 0, "east": 0, "down": -30, "alt": 30, "lat": lat, "lon": lon}
    world = WorldModel.model_validate({"timestamp": 1.0, "objects": [], "relations": [], "ego_pose": ego})
    assert [r.key for r in memory.recall(world, None)] == ["R1:5"]
    memory.fleet.close()
