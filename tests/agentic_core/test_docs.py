"""The runnable examples in the docstrings of public entry points stay true."""

import doctest
import importlib

import pytest

MODULES = [
    "agentic_core.graph",
    "agentic_core.graph.graph",
    "agentic_core.graph.types",
    "agentic_core.graph.checkpoint.memory",
    "agentic_core.graph.checkpoint.sqlite",
    "agentic_core.demo",
    "agentic_core.mission.expressions",
    "agentic_core.mission.model",
    "agentic_core.mission.validate",
    "flight.camera",
    "evaluation.stats.plots",
    "prompts",
    "agentic_core.reasoning.assessment",
    "agentic_core.reasoning.proposal",
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
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no runnable example"
    assert result.failed == 0
