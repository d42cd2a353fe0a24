"""A mission drawn as a Mermaid flowchart (``agentic-uav plan --mermaid``): its steps with their actions, the
dependencies between them, the steps a ``repeat`` or ``branch`` holds, and each trigger with its condition and
sub-plan — the mission as written, not the graph runtime's internal nodes.

>>> from agentic_core.mission import load_mission
>>> text = mission_mermaid(load_mission("missions/inspect_perimeter.yaml"))
>>> text.splitlines()[0], "check_weather --> inspect_anomaly" in text
('flowchart TD', True)
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

from ..contracts.policy_graph import BranchStep, CallToolStep, PolicyGraph, RepeatStep, Step


def _text(text: str) -> str:
    """A label Mermaid reads as text whatever it holds (quotes, brackets, ``<``)."""
    return text.replace("&", "&amp;").replace('"', "#quot;").replace("<", "&lt;").replace(">", "&gt;")


def _node(step: Step) -> str:
    what = f"call_tool {step.tool}" if isinstance(step, CallToolStep) else step.action
    marks = ["approval"] * step.approval + [f"if {c}" for c in step.preconditions]
    detail = "".join(f"<br/><i>{_text(m)}</i>" for m in marks)
    return f'{step.id}["<b>{step.id}</b><br/>{_text(what)}{detail}"]'


class _Drawing:
    def __init__(self, plan: PolicyGraph) -> None:
        self.plan = plan
        self.lines = ["flowchart TD"]

    def steps(self, steps: Sequence[Step], indent: str, in_order: bool = False) -> None:
        """``steps`` and their edges: their dependencies, or with ``in_order`` (a repeat's round, a branch's arm)
        one after another."""
        for step in steps:
            if isinstance(step, RepeatStep):
                self.group(step.id, f"{step.id}: repeat until {step.until}", step.steps, indent)
            elif isinstance(step, BranchStep):
                self.group(step.id, f"{step.id}: if {step.if_}", step.then, indent)
                if step.else_:
                    self.group(f"{step.id}_else", f"{step.id}: else", step.else_, indent)
                    self.lines.append(f"{indent}{step.id} -.->|else| {step.id}_else")
            else:
                self.lines.append(f"{indent}{_node(step)}")
        if in_order:
            self.lines += [f"{indent}{a.id} --> {b.id}" for a, b in itertools.pairwise(steps)]
            return
        for step in steps:
            for dep in [*step.depends_on, *self.plan.dependencies.get(step.id, [])]:
                self.lines.append(f"{indent}{dep} --> {step.id}")

    def group(self, name: str, title: str, steps: Sequence[Step], indent: str, in_order: bool = True) -> None:
        self.lines.append(f'{indent}subgraph {name}["{_text(title)}"]')
        self.lines.append(f"{indent}  direction TB")
        self.steps(steps, indent + "  ", in_order=in_order)
        self.lines.append(f"{indent}end")


def mission_mermaid(plan: PolicyGraph) -> str:
    """The Mermaid flowchart of ``plan``: steps, dependencies (solid arrows), triggers (hexagons) and the sub-plans
    they start (dotted arrows)."""
    drawing = _Drawing(plan)
    drawing.steps(plan.steps, "  ")
    for trigger in plan.triggers:
        name = f"trigger_{trigger.id}"
        how = "pre-empts the plan" if trigger.preempt else "runs beside the plan"
        plan_by = "; plan by the reasoner" if trigger.plan == "reasoner" else ""
        drawing.lines.append(f'  {name}{{{{"<b>trigger {trigger.id}</b><br/>when {_text(trigger.when)}"}}}}')
        drawing.group(f"{name}_steps", f"{trigger.id}: {how}{plan_by}", trigger.steps, "  ", in_order=False)
        drawing.lines.append(f"  {name} -.->|fires| {name}_steps")
    return "\n".join(drawing.lines) + "\n"


__all__ = ["mission_mermaid"]
