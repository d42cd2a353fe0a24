"""The plan's steps in dependency layers (the supersteps they run in if nothing fails): a static view, not compiling."""

from __future__ import annotations

from .model import PolicyGraph


def layers(plan: PolicyGraph) -> list[list[str]]:
    """The plan's steps grouped by the superstep they run in when nothing fails (topological generations)."""
    import networkx as nx

    graph = nx.DiGraph()
    for step in plan.steps:
        graph.add_node(step.id)
        for dep in [*step.depends_on, *plan.dependencies.get(step.id, [])]:
            graph.add_edge(dep, step.id)
    return [sorted(gen) for gen in nx.topological_generations(graph)]
