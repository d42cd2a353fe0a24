"""The structure of a graph as Mermaid flowchart text (``compiled.get_graph().draw_mermaid()``)."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from .constants import END, START

if TYPE_CHECKING:
    from .graph import StateGraph


@dataclass(frozen=True)
class Edge:
    source: str
    target: str
    conditional: bool = False
    label: str | None = None


@dataclass
class DrawableGraph:
    """Nodes and edges as drawn; conditional edges are dotted and labelled with their router's key."""

    nodes: list[str]
    edges: list[Edge] = field(default_factory=list)

    @classmethod
    def from_builder(cls, builder: StateGraph) -> DrawableGraph:
        graph = cls(nodes=[START, *builder.nodes, END])
        for a, b in builder.edges:
            graph.edges.append(Edge(a, b))
        for join in builder.joins:
            for s in join.sources:
                graph.edges.append(Edge(s, join.target))
        for br in builder.branches:
            if br.path_map is None:
                continue
            for key, target in br.path_map.items():
                label = None if str(key) == target else str(key)
                graph.edges.append(Edge(br.source, target, conditional=True, label=label))
        for spec in builder.nodes.values():
            for target in spec.destinations or ():
                graph.edges.append(Edge(spec.name, target, conditional=True))
        return graph

    def _ids(self) -> dict[str, str]:
        """Mermaid-safe ids, unique even where two names differ only in characters Mermaid cannot take."""
        ids: dict[str, str] = {}
        taken: set[str] = set()
        for name in self.nodes:
            base = name if name in (START, END) else re.sub(r"[^0-9A-Za-z_]", "_", name)
            candidate, n = base, 1
            while candidate in taken:
                n += 1
                candidate = f"{base}_{n}"
            ids[name] = candidate
            taken.add(candidate)
        return ids

    def draw_mermaid(self) -> str:
        """Mermaid text; paste it into any Mermaid renderer (GitHub renders it in Markdown)."""
        ids = self._ids()
        lines = ["---", "config:", "  flowchart:", "    curve: linear", "---", "graph TD;"]
        for node in self.nodes:
            if node == START:
                lines.append(f"\t{ids[node]}([<p>{START}</p>]):::first")
            elif node == END:
                lines.append(f"\t{ids[node]}([<p>{END}</p>]):::last")
            else:
                lines.append(f'\t{ids[node]}("{node}")')
        for e in self.edges:
            a, b = ids[e.source], ids[e.target]
            if not e.conditional:
                lines.append(f"\t{a} --> {b};")
            elif e.label:
                lines.append(f"\t{a} -. &nbsp;{e.label}&nbsp; .-> {b};")
            else:
                lines.append(f"\t{a} -.-> {b};")
        lines += [
            "\tclassDef default fill:#f2f0ff,line-height:1.2",
            "\tclassDef first fill-opacity:0",
            "\tclassDef last fill:#bfb6fc",
        ]
        return "\n".join(lines) + "\n"
