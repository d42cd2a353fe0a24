"""The tools of one run: the built-ins (configured for the run's folder), installed plugins and every ``--tools``
source, loaded by the one loader ``validate --tools`` and ``mcp serve`` use (:func:`tools.loading.build_registry`);
and the agent's caller, which holds the scopes the tools it was given declare.

>>> from tools.builtin.config import BuiltinConfig
>>> registry, agent = run_tools(["tests/tools/mcp/sample_tools.py"], BuiltinConfig(), plugins=False)
>>> "sample.wind" in registry and agent.allows("weather:read") and agent.id == "agent"
True
"""

from __future__ import annotations

from collections.abc import Sequence

from tools import Caller, ToolRegistry
from tools.builtin.config import BuiltinConfig
from tools.loading import build_registry

from .own_tools import reserved_names
from .settings import AGENT


def run_tools(sources: Sequence[str], config: BuiltinConfig, *, plugins: bool = True) -> tuple[ToolRegistry, Caller]:
    """The run's registry and the agent that may call every tool in it. A source that cannot be loaded, or that
    defines a tool the run registers itself (``flight.fly_to``), raises :class:`~tools.errors.ToolDefinitionError`
    (bad input, exit 2) naming it, before anything flies."""
    registry = build_registry(sources, config=config, plugins=plugins, reserved=reserved_names())
    granted = {scope for name in registry.names() for scope in registry.get(name).scopes}
    return registry, AGENT.model_copy(update={"scopes": AGENT.scopes | granted})


__all__ = ["run_tools"]
