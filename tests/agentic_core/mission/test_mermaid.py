"""``agentic-uav plan --mermaid`` draws the mission as written: every step, every dependency, every trigger with
its condition and sub-plan, and none of the runtime's internal nodes; any text in a label stays text."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from agentic_core.cli import main
from agentic_core.mission import load_mission
from agentic_core.mission.mermaid import mission_mermaid
from agentic_core.mission.validate import iter_steps

REPO = Path(__file__).resolve().parents[3]
SHIPPED = sorted((REPO / "missions").glob("*.yaml"))


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_a_shipped_mission_is_drawn_as_its_steps_dependencies_and_triggers(
    path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["plan", str(path), "--mermaid"]) == 0
    text = capsys.readouterr().out
    assert text == mission_mermaid(load_mission(path)) and text.startswith("flowchart TD\n")
    plan = load_mission(path)
    lines = [line.strip() for line in text.splitlines()]
    for step in (site.step for site in iter_steps(plan)):
        drawn = [line for line in lines if line.startswith((f'{step.id}["', f'subgraph {step.id}["'))]
        assert len(drawn) == 1, step.id
        assert step.action in drawn[0] or drawn[0].startswith("subgraph")
        for dep in step.depends_on:
            assert f"{dep} --> {step.id}" in lines
    for trigger in plan.triggers:
        assert any(line.startswith(f"trigger_{trigger.id}{{{{") for line in lines)
        assert f"trigger_{trigger.id} -.->|fires| trigger_{trigger.id}_steps" in lines
    assert not re.search(r"__(start|end|schedule|reflect|abort|rtl|dynamic)__", text)
    for line in lines:  # every label is one quoted string: no stray quote can end it early
        label = re.search(r'\["(.*)"\]|\{\{"(.*)"\}\}', line)
        if label:
            assert '"' not in (label.group(1) or label.group(2) or ""), line


def test_quotes_and_brackets_in_a_mission_stay_text() -> None:
    from agentic_core.contracts.policy_graph import PolicyGraph

    hover = {"id": "a", "action": "hover", "args": {"duration_s": 1}, "preconditions": ['vehicle.mode != "x<y>"']}
    trigger = {"id": "t", "when": 'len(world.objects) > 2 and "]" != ""', "steps": [{"id": "b", "action": "rtl"}]}
    plan = PolicyGraph.model_validate({"plan_id": "p", "goal": "g", "steps": [hover], "triggers": [trigger]})
    text = mission_mermaid(plan)
    assert 'a["<b>a</b><br/>hover<br/><i>if vehicle.mode != #quot;x&lt;y&gt;#quot;</i>"]' in text
    assert "&gt; 2 and #quot;]#quot; != #quot;#quot;" in text
