"""One error root: every exception class the project defines derives from AgenticUAVError."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from types import ModuleType

import pytest

from agentic_core.contracts import AgenticUAVError, InputError, RunFailure

PACKAGES = ("agentic_core", "tools", "flight", "evaluation", "prompts")


def _modules() -> list[ModuleType]:
    found: list[ModuleType] = []
    for name in PACKAGES:
        package = importlib.import_module(name)
        found.append(package)
        for info in pkgutil.walk_packages(package.__path__, prefix=f"{name}."):
            if info.name.endswith("__main__"):
                continue
            found.append(importlib.import_module(info.name))
    return found


def _defined_exceptions() -> dict[str, type[BaseException]]:
    classes: dict[str, type[BaseException]] = {}
    for module in _modules():
        for _, value in inspect.getmembers(module, inspect.isclass):
            if issubclass(value, BaseException) and value.__module__ == module.__name__:
                classes[f"{value.__module__}.{value.__qualname__}"] = value
    return classes


def test_the_walk_sees_the_projects_exceptions() -> None:
    names = _defined_exceptions()
    for expected in (
        "agentic_core.mission.source.MissionError",
        "flight.sim.scene_file.SceneFileError",
        "tools.errors.ToolError",
        "evaluation.stats.errors.InputError",
        "agentic_core.graph.errors.GraphError",
    ):
        assert expected in names
    assert len(names) >= 40


def test_every_exception_the_project_defines_derives_from_the_root() -> None:
    strays = sorted(name for name, cls in _defined_exceptions().items() if not issubclass(cls, AgenticUAVError))
    assert strays == []


@pytest.mark.parametrize(
    ("dotted", "kind"),
    [
        ("agentic_core.mission.source.MissionError", InputError),
        ("flight.sim.scene_file.SceneFileError", InputError),
        ("evaluation.stats.errors.InputError", InputError),
        ("evaluation.campaign.records.RecordFileError", InputError),
        ("tools.errors.ToolDefinitionError", InputError),
        ("agentic_core.reasoning.reasoners.ReasonerError", InputError),
        ("agentic_core.run.settings.RunError", InputError),
        ("tools.errors.ToolError", RunFailure),
        ("flight.client.link.VehicleConnectionError", RunFailure),
    ],
)
def test_user_input_and_run_failures_have_their_branch(dotted: str, kind: type[AgenticUAVError]) -> None:
    module, _, name = dotted.rpartition(".")
    assert issubclass(getattr(importlib.import_module(module), name), kind)


def test_old_bases_are_kept() -> None:
    from agentic_core.graph.errors import GraphRecursionError, NodeTimeoutError
    from prompts import PromptError
    from tools.errors import CallTimeout, UnknownToolError

    assert issubclass(UnknownToolError, KeyError)
    assert issubclass(PromptError, KeyError)
    assert issubclass(CallTimeout, TimeoutError)
    assert issubclass(GraphRecursionError, RecursionError)
    assert issubclass(NodeTimeoutError, TimeoutError)
