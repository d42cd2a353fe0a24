"""The contracts moved into agentic_core.contracts: the old modules hand out the same classes, never copies, and
importing a contract (or reading a mission or scene file) loads nothing heavy."""

from __future__ import annotations

import ast
import importlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

import agentic_core.contracts

MOVED = [
    ("agentic_core.mission.model", "agentic_core.contracts.policy_graph", "PolicyGraph"),
    ("agentic_core.mission.model", "agentic_core.contracts.action_args", "TakeoffArgs"),
    ("agentic_core.mission.model", "agentic_core.contracts.mission_limits", "Limits"),
    ("agentic_core.perception.world_model", "agentic_core.contracts.world_model", "WorldModel"),
    ("agentic_core.perception.world_model", "agentic_core.contracts.world_model", "WorldObject"),
    ("agentic_core.reasoning.assessment", "agentic_core.contracts.assessment", "Assessment"),
    ("agentic_core.reasoning.assessment", "agentic_core.contracts.assessment", "Decision"),
    ("agentic_core.reasoning.proposal", "agentic_core.contracts.plan", "Proposal"),
    ("tools.result", "agentic_core.contracts.tool_result", "ToolResult"),
    ("tools.security", "agentic_core.contracts.tool_result", "InjectionReport"),
    ("flight.camera", "agentic_core.contracts.camera", "Detection"),
    ("flight.camera", "agentic_core.contracts.camera", "Frame"),
    ("flight.camera", "agentic_core.contracts.camera", "Detector"),
    ("flight.camera", "agentic_core.contracts.camera", "CameraSpec"),
]


@pytest.mark.parametrize(("old", "new", "name"), MOVED)
def test_the_old_module_hands_out_the_contracts_class(old: str, new: str, name: str) -> None:
    moved = getattr(importlib.import_module(new), name)
    assert getattr(importlib.import_module(old), name) is moved
    assert moved.__module__ == new


def test_decision_and_decision_record_are_one_class() -> None:
    from agentic_core.contracts.assessment import Decision, DecisionRecord

    assert Decision is DecisionRecord


SAME_NAME_OTHER_THING = {
    "flight/sim/scene_model.py: Circle",  # a scene zone's circle in local metres, not the mission's lat/lon circle
    "flight/sim/scene_model.py: Landmark",  # a scene file's landmark (ground truth), not the world model's
    "flight/mavlink/geofence.py: Circle",  # the vehicle's stored fence circle, local metres
    "flight/sim/controller.py: Limits",  # the simulated controller's speed and tilt limits
    "agentic_core/reasoning/llm/messages.py: ToolCall",  # a model server's call (OpenAI/Ollama wire), not a message's
}


def test_no_class_is_defined_twice() -> None:
    """A class name the contracts define is not defined again (a copy) in any module of the project."""
    contract_classes = {
        node.name
        for path in Path(agentic_core.contracts.__file__).parent.glob("*.py")
        for node in ast.parse(path.read_text()).body
        if isinstance(node, ast.ClassDef) and not node.name.startswith("_") and node.name != "Contract"
    }
    root = Path(agentic_core.contracts.__file__).parents[2]
    copies = []
    for package in ("agentic_core", "tools", "flight", "prompts"):
        for path in (root / package).rglob("*.py"):
            if "contracts" in path.parts:
                continue
            for node in ast.parse(path.read_text()).body:
                if isinstance(node, ast.ClassDef) and node.name in contract_classes:
                    copies.append(f"{path.relative_to(root)}: {node.name}")
    assert sorted(set(copies) - SAME_NAME_OTHER_THING) == []


def test_the_contracts_import_nothing_of_the_project() -> None:
    ours = {"agentic_core", "tools", "flight", "evaluation", "prompts"}
    found = []
    for path in Path(agentic_core.contracts.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found += [a.name for a in node.names if a.name.split(".")[0] in ours]
            elif (
                isinstance(node, ast.ImportFrom)
                and node.level == 0
                and node.module
                and node.module.split(".")[0] in ours
            ):
                found.append(node.module)
    assert found == []


HEAVY = ("jsbsim", "scipy", "pymavlink")


def _loaded_after(code: str, heavy: tuple[str, ...] = HEAVY) -> list[str]:
    root = Path(agentic_core.contracts.__file__).parents[2]
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run(
        [sys.executable, "-c", probe], cwd=root, capture_output=True, text=True, timeout=120, check=True
    ).stdout
    modules: list[str] = json.loads(out.strip().splitlines()[-1])
    return [m for m in modules if m.split(".")[0] in heavy]


def test_importing_every_contract_loads_nothing_heavy() -> None:
    names = sorted(p.stem for p in Path(agentic_core.contracts.__file__).parent.glob("*.py") if p.stem != "__init__")
    code = "import agentic_core.contracts\n" + "".join(f"import agentic_core.contracts.{n}\n" for n in names)
    assert "import agentic_core.contracts.camera" in code
    assert _loaded_after(code) == []


def test_loading_a_mission_file_loads_nothing_heavy() -> None:
    root = Path(agentic_core.contracts.__file__).parents[2]
    mission = sorted((root / "missions").glob("*.yaml"))[0]
    code = f"from agentic_core.mission import load_mission\nprint(load_mission({str(mission)!r}).plan_id)"
    assert _loaded_after(code) == []


def test_loading_a_scene_file_loads_nothing_heavy() -> None:
    root = Path(agentic_core.contracts.__file__).parents[2]
    scene = sorted((root / "scenes").glob("*.yaml"))[0]
    code = f"from flight.sim.scene_file import load_scene\nprint(load_scene({str(scene)!r}).id)"
    assert _loaded_after(code) == []


def test_a_run_imports_matplotlib_only_to_write_its_report() -> None:
    """A third of a run's start-up was matplotlib, needed only for the report's plots at the end: a run killed, or a
    process that only assembles one, no longer pays for it."""
    code = "import agentic_core.run.runner, agentic_core.run.report, agentic_core.run.assembly"
    assert _loaded_after(code, heavy=("matplotlib",)) == []
    assert _loaded_after(code + "\nfrom agentic_core.run.plots import flight", heavy=("matplotlib",)) != []
