"""Fault: one failure a user schedules to rehearse a failsafe — ``agentic-uav run --fault battery=18%@S1``, or the
same text in a scene file's ``faults:`` list. The run delivers it to the vehicle as MAV_CMD_INJECT_FAILURE.

The text form is ``KIND[=VALUE]@WHEN``:

* KIND: ``battery`` (with ``=N%``: the battery reads N percent from then on), ``battery_low``, ``battery_critical``
  (just under the vehicle's own thresholds), ``gps_loss``, ``link_loss``, ``motor`` (with ``=N``: motor N, 1 to 4).
* WHEN: ``t=40s`` (seconds of mission time: the vehicle's clock since the run's first telemetry sample), or a step
  id (``S1``: when that step has completed, i.e. the aircraft arrived).

>>> parse_fault("battery=18%@S1")
Fault(fault='battery', value=18.0, at_s=None, at_step='S1')
>>> parse_fault("gps_loss@t=40s").at_s
40.0
>>> parse_fault("battery@S1")
Traceback (most recent call last):
...
ValueError: 'battery@S1': battery needs a level, e.g. battery=18%@S1
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal, cast

from pydantic import BaseModel, ConfigDict, Field, WithJsonSchema, model_validator

FaultKind = Literal["battery", "battery_low", "battery_critical", "gps_loss", "link_loss", "motor"]
FAULT_KINDS: tuple[str, ...] = ("battery", "battery_low", "battery_critical", "gps_loss", "link_loss", "motor")
MOTORS = 4

_FORM = re.compile(r"^(?P<kind>[a-z_]+)(?:=(?P<value>[^@]*))?@(?P<when>.*)$")
_STEP = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_TIME = re.compile(r"^t=(?P<t>[0-9]+(?:\.[0-9]+)?)s?$")
FORM_HELP = "KIND[=VALUE]@WHEN, e.g. battery=18%@S1 or gps_loss@t=40s"


class Fault(BaseModel):
    """One scheduled failure: what fails, how much, and when (mission time, or a step's completion)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    fault: FaultKind
    value: float | None = Field(default=None, description="battery: the level in percent; motor: its number")
    at_s: float | None = Field(default=None, ge=0, description="seconds of mission time")
    at_step: str | None = Field(default=None, pattern=_STEP.pattern, description="when this step has completed")

    @model_validator(mode="before")
    @classmethod
    def _from_text(cls, data: Any) -> Any:
        return parse_fault(data).model_dump() if isinstance(data, str) else data

    @model_validator(mode="after")
    def _consistent(self) -> Fault:
        if (self.at_s is None) == (self.at_step is None):
            raise ValueError("a fault needs one time: at_s (mission seconds) or at_step (a step id)")
        problem = value_problem(self.fault, self.value)
        if problem:
            raise ValueError(problem)
        return self

    def text(self) -> str:
        """The fault in its command-line form."""
        value = "" if self.value is None else f"={self.value:g}%" if self.fault == "battery" else f"={self.value:g}"
        when = f"t={self.at_s:g}s" if self.at_s is not None else str(self.at_step)
        return f"{self.fault}{value}@{when}"


FaultText = Annotated[
    Fault,
    WithJsonSchema({"type": "string", "pattern": _FORM.pattern, "description": f"a fault: {FORM_HELP}"}),
]
"""A fault as files write it: its text form (a mapping of :class:`Fault`'s fields is read too)."""


def value_problem(kind: str, value: float | None) -> str | None:
    """Why ``value`` does not suit a fault of ``kind``, or None."""
    if kind == "battery":
        if value is None:
            return "battery needs a level, e.g. battery=18%@S1"
        if not (math.isfinite(value) and 0 <= value <= 100):
            return f"a battery level is 0 to 100 percent, not {value:g}"
    elif kind == "motor":
        if value is None or value != int(value) or not 1 <= value <= MOTORS:
            return f"motor needs its number, 1 to {MOTORS}, e.g. motor=1@t=30s"
    elif value is not None:
        return f"{kind} takes no value"
    return None


def parse_fault(text: str) -> Fault:
    """A fault from its text form (see the module docstring); ValueError naming what is wrong."""
    found = _FORM.match(text.strip())
    if found is None:
        raise ValueError(f"{text!r}: expected {FORM_HELP}")
    kind, raw, when = found["kind"], found["value"], found["when"]
    if kind not in FAULT_KINDS:
        raise ValueError(f"{text!r}: no fault {kind!r}; the faults are {', '.join(FAULT_KINDS)}")
    value: float | None = None
    if raw is not None:
        number = raw.removesuffix("%") if kind == "battery" else raw
        if kind == "battery" and not raw.endswith("%"):
            raise ValueError(f"{text!r}: a battery level is a percentage, e.g. battery=18%")
        try:
            value = float(number)
        except ValueError:
            raise ValueError(f"{text!r}: {raw!r} is not a number") from None
    problem = value_problem(kind, value)
    if problem:
        raise ValueError(f"{text!r}: {problem}")
    timed = _TIME.match(when)
    if timed is not None:
        return Fault(fault=cast(FaultKind, kind), value=value, at_s=float(timed["t"]))
    if _STEP.match(when):
        return Fault(fault=cast(FaultKind, kind), value=value, at_step=when)
    raise ValueError(f"{text!r}: {when!r} is not a time (t=40s) or a step id")


__all__ = ["FAULT_KINDS", "FORM_HELP", "Fault", "FaultKind", "FaultText", "parse_fault", "value_problem"]
