"""RunEvent: one thing that happened in a run — a step, a tool call, a decision, a trigger, an approval, a
control command, a failsafe — as published on the run's event bus. ``trace.jsonl`` holds one per line; the
console and the memory layer subscribe to the same bus.

The envelope (``kind``, ``seq``, ``t``, ``sim_t``, ``summary``) is typed; each kind adds its own fields at the top
level, so a trace line is flat JSON (``{"kind": "tool", "name": "flight.takeoff", "status": "ok", ...}``).

>>> e = RunEvent(kind="tool", seq=3, sim_t=12.5, name="flight.takeoff", status="ok")
>>> e.model_dump(mode="json")["name"], e.fields()["status"]
('flight.takeoff', 'ok')
"""

from __future__ import annotations

import time
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

EVENT_KINDS = frozenset(
    {
        "run",  # start, end, resume of the run
        "step",  # a mission step changed status
        "tool",  # a tool call and its result
        "decision",  # the reasoner assessed the scene or an object
        "trigger",  # a trigger's tier-1 rule held, and whether tier 2 let it act
        "mission",  # the mission's own log: fired, planned, replaced, ...
        "refusal",  # a model's plan or revision refused, with every reason
        "plan",  # a response plan asked of the model
        "reflection",  # a revision asked of the model
        "approval",  # a question to the operator and its answer
        "control",  # a command on the control port (pause, resume, abort, rtl, land, approve, decline)
        "failsafe",  # a failsafe, the agent's or the vehicle's
        "fault",  # a scheduled fault delivered to the vehicle (or not)
        "alert",  # an alert that left
        "memory",  # the fleet's memory: what was recalled at the start, what was recorded at the end
        "log",  # anything else worth a line
    }
)
"""The kinds of event a run publishes."""


class RunEvent(BaseModel):
    """One event of a run; the kind's own fields sit beside the envelope's."""

    model_config = ConfigDict(extra="allow", frozen=True)

    kind: str = Field(description="what happened: one of EVENT_KINDS")
    seq: int = Field(default=0, ge=0, description="position in the run's event stream, from 1")
    t: float = Field(default_factory=lambda: round(time.time(), 6), description="wall time, Unix seconds")
    sim_t: float | None = Field(default=None, description="the vehicle's clock (simulated seconds in a simulation)")
    summary: str | None = Field(default=None, description="one line for a person")

    def fields(self) -> dict[str, Any]:
        """The kind's own fields (everything beside the envelope)."""
        return dict(self.__pydantic_extra__ or {})


def run_event_json_schema() -> dict[str, Any]:
    """The JSON Schema of :class:`RunEvent`."""
    return RunEvent.model_json_schema()


__all__ = ["EVENT_KINDS", "RunEvent", "run_event_json_schema"]
