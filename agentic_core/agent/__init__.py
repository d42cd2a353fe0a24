"""The agent loop and its ports (the paper's Reasoning layer, as it runs): typed ports to the vehicle, the world,
the reasoner and the operator; one trigger evaluation (``agentic_core.mission.triggers``) used at the scheduler's
barriers and while a long action flies; the tier-2 gate; the dispatcher every action goes through; the control
port; the event bus; pacing of simulated time.

>>> from agentic_core.agent import ControlPort, EventBus
>>> bus, seen = EventBus(), []
>>> _ = bus.subscribe(lambda event: seen.append(event.kind))
>>> port = ControlPort(on_command=lambda name, detail: bus.publish("control", command=name, **detail))
>>> port.pause(by="console")
>>> seen, port.paused
(['control'], True)
"""

from .bus import EventBus
from .control import ControlPort, OperatorAnswer, Question
from .dispatch import WATCHED_TOOLS, Dispatcher
from .gate import ACT_AT, Gate, acts
from .loop import AgentLoop, LoopResult, policy_approval
from .pacing import Pace
from .ports import ReasonerPort, VehicleView, WorldSource

__all__ = [
    "ACT_AT",
    "WATCHED_TOOLS",
    "AgentLoop",
    "ControlPort",
    "Dispatcher",
    "EventBus",
    "Gate",
    "LoopResult",
    "OperatorAnswer",
    "Pace",
    "Question",
    "ReasonerPort",
    "VehicleView",
    "WorldSource",
    "acts",
    "policy_approval",
]
