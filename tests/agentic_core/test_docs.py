"""The runnable examples in the docstrings of public entry points stay true."""

import doctest
import importlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

MODULES = [
    "agentic_core.contracts",
    "agentic_core.contracts.assessment",
    "agentic_core.contracts.camera",
    "agentic_core.contracts.errors",
    "agentic_core.contracts.events",
    "agentic_core.contracts.plan",
    "agentic_core.contracts.policy_graph",
    "agentic_core.contracts.telemetry",
    "agentic_core.contracts.tool_result",
    "agentic_core.contracts.world_model",
    "agentic_core.graph",
    "agentic_core.graph.graph",
    "agentic_core.graph.types",
    "agentic_core.graph.checkpoint.memory",
    "agentic_core.graph.message",
    "agentic_core.contracts.messages",
    "agentic_core.prebuilt",
    "agentic_core.prebuilt.tool_node",
    "agentic_core.graph.checkpoint.sqlite",
    "agentic_core.demo",
    "agentic_core.mission.expressions",
    "agentic_core.mission.model",
    "agentic_core.mission.validate",
    "flight.camera",
    "flight.sim.scene_model",
    "flight.sim.scene",
    "flight.sim.scene_file",
    "flight.sim.scene_gen",
    "flight.sim.detector",
    "evaluation.stats.plots",
    "evaluation.campaign.records",
    "evaluation.campaign.systems",
    "evaluation.campaign.episode",
    "evaluation.campaign.manifest",
    "evaluation.campaign.progress",
    "evaluation.campaign.metrics",
    "evaluation.campaign.runner",
    "prompts",
    "agentic_core.reasoning.assessment",
    "agentic_core.reasoning.proposal",
    "agentic_core.reasoning.rules",
    "agentic_core.perception",
    "agentic_core.perception.annotate",
    "agentic_core.perception.association",
    "agentic_core.contracts.polygon",
    "agentic_core.contracts.geodesy",
    "agentic_core.perception.kalman",
    "agentic_core.perception.measurement",
    "agentic_core.perception.metrics",
    "agentic_core.perception.pipeline",
    "agentic_core.perception.scene_graph",
    "agentic_core.perception.tracker",
    "agentic_core.perception.world_model",
    "agentic_core.run.perception_loop",
    "agentic_core.run.trace",
    "agentic_core.run.cli",
    "agentic_core.reasoning.reasoners",
    "agentic_core.reasoning.llm",
    "agentic_core.reasoning.llm.client",
    "agentic_core.reasoning.llm.config",
    "agentic_core.reasoning.llm.factory",
    "agentic_core.reasoning.llm.messages",
    "agentic_core.reasoning.llm.ollama",
    "agentic_core.reasoning.llm.openai_compat",
    "agentic_core.reasoning.llm.result",
    "agentic_core.reasoning.llm.structured",
    "agentic_core.reasoning.llm.transport",
    "tools",
    "tools.auth",
    "tools.breaker",
    "tools.cache",
    "tools.executor",
    "tools.function",
    "tools.loading",
    "tools.ratelimit",
    "tools.registry",
    "tools.result",
    "tools.spec",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(REPO)  # examples may read the shipped missions/ and scenes/
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no runnable example"
    assert result.failed == 0
