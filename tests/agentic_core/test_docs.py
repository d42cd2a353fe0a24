"""The runnable examples in the docstrings of public entry points stay true."""

import doctest
import importlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

PACKAGES = ("agentic_core", "tools", "flight", "evaluation", "prompts")

LISTED = [
    "agentic_core.contracts",
    "agentic_core.contracts.assessment",
    "agentic_core.contracts.camera",
    "agentic_core.contracts.errors",
    "agentic_core.contracts.extras",
    "agentic_core.contracts.events",
    "agentic_core.contracts.plan",
    "agentic_core.contracts.policy_graph",
    "agentic_core.contracts.telemetry",
    "agentic_core.contracts.tool_result",
    "agentic_core.contracts.world_model",
    "agentic_core.contracts.campaign_progress",
    "agentic_core.run.fork",
    "agentic_core.run.world_map",
    "agentic_core.console.launch",
    "agentic_core.console.campaigns",
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
    "agentic_core.examples",
    "agentic_core.examples.cli",
    "agentic_core.mission.expressions",
    "agentic_core.mission.model",
    "agentic_core.mission.validate",
    "flight.camera",
    "flight.sim.scene_model",
    "flight.sim.scene",
    "flight.sim.scene_file",
    "flight.sim.gains_file",
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
    "evaluation.campaign.executors",
    "evaluation.campaign.jobs",
    "evaluation.campaign.model_calls",
    "evaluation.campaign.budget",
    "evaluation.campaign.early_stop",
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
    "agentic_core.agent",
    "agentic_core.agent.bus",
    "agentic_core.agent.control",
    "agentic_core.agent.envelope",
    "agentic_core.agent.failsafes",
    "agentic_core.agent.pacing",
    "agentic_core.run.backends",
    "agentic_core.run.link_key",
    "agentic_core.run.perception_loop",
    "agentic_core.run.trace",
    "agentic_core.run.stops",
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
    "agentic_core.contracts.swarm",
    "agentic_core.swarm",
    "agentic_core.swarm.signing",
    "agentic_core.swarm.card",
    "agentic_core.swarm.a2a_server",
    "agentic_core.swarm.a2a_client",
    "agentic_core.swarm.a2a_extra",
    "agentic_core.swarm.cost",
    "agentic_core.swarm.contract_net",
    "agentic_core.swarm.optimal",
    "agentic_core.swarm.deconflict",
    "agentic_core.swarm.fusion",
    "agentic_core.swarm.sectors",
    "agentic_core.swarm.consensus",
    "agentic_core.swarm.card_signing",
    "agentic_core.swarm.projection",
    "agentic_core.swarm.separation",
    "agentic_core.swarm.coordinator",
    "agentic_core.swarm.fleet_tools",
    "agentic_core.swarm.legs",
    "agentic_core.swarm.leg_gate",
    "agentic_core.run.swarm_airspace",
    "agentic_core.contracts.swarm_plan",
    "agentic_core.run.swarm_cli",
    "flight.mavlink.lockstep",
    "flight.cli",
    "flight.client.safety",
    "flight.client.streams",
    "flight.client.telemetry",
    "flight.mavlink.guard",
    "flight.mavlink.links",
    "flight.mavlink.pacing",
    "flight.signing",
    "flight.sim.snapshot",
    "agentic_core.reasoning.knowledge",
    "agentic_core.perception.calibration",
    "agentic_core.perception.detectors.yolo_decode",
    "agentic_core.perception.detectors.onnx",
    "agentic_core.run.detector_choice",
    "agentic_core.perception.detectors.ours",
    "evaluation.detector.crops",
    "evaluation.detector.scoring",
    "evaluation.detector.evaluate",
]


def modules_with_examples() -> list[str]:
    """Every module of the five packages whose source holds a ``>>>`` example (the listed ones must)."""
    found = []
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            if path.name == "__main__.py" or ">>>" not in path.read_text(encoding="utf-8"):
                continue
            parts = path.relative_to(REPO).with_suffix("").parts
            found.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return found


MODULES = sorted(set(modules_with_examples()) | set(LISTED))


def test_every_listed_public_entry_point_has_its_example_found() -> None:
    assert set(LISTED) <= set(modules_with_examples())


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(REPO)  # examples may read the shipped missions/ and scenes/
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 or name not in LISTED, f"{name} has no runnable example"
    assert result.failed == 0
