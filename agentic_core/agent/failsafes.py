"""Failsafes on telemetry: the mission's ``min_battery_pct`` acts — below it, in the air, the agent ends the
mission and returns home (through the control port, as an operator's RTL would, with ``by="failsafe"``) and says so
in a ``failsafe`` event. No scene or reasoner is involved: the check reads the vehicle's own telemetry samples.

>>> from agentic_core.agent.control import ControlPort
>>> from agentic_core.contracts import TelemetrySample
>>> from agentic_core.contracts.policy_graph import Limits
>>> port, said = ControlPort(), []
>>> watch = TelemetryFailsafes(Limits(min_battery_pct=25), port, lambda kind, **f: said.append(f["summary"]))
>>> sample = dict(time_s=40.0, lat_deg=21.4, lon_deg=39.9, alt_m=30.0, north_m=0, east_m=0, down_m=-30)
>>> watch(TelemetrySample(**sample, battery_pct=18.0, armed=True, landed_state="in_air"))
>>> port.stop_requested(), said[0]
('rtl', "battery 18% is below the mission's 25%: returning home")
"""

from __future__ import annotations

import threading

from ..contracts import TelemetrySample
from ..contracts.policy_graph import Limits
from .control import ControlPort
from .ports import Publish


class TelemetryFailsafes:
    """A telemetry hook that turns the mission's battery limit into a return home, once."""

    def __init__(self, limits: Limits | None, control: ControlPort, publish: Publish) -> None:
        self.limits = limits or Limits()
        self.control = control
        self.publish = publish
        self._lock = threading.Lock()
        self.fired: str | None = None

    def __call__(self, sample: TelemetrySample) -> None:
        floor = self.limits.min_battery_pct
        if floor is None or sample.battery_pct is None or sample.battery_pct >= floor:
            return
        if not sample.armed or sample.landed_state == "on_ground":
            return
        with self._lock:
            if self.fired is not None:
                return
            self.fired = "battery"
        self.publish(
            "failsafe", failsafe="battery", battery_pct=sample.battery_pct, limit_pct=floor, action="rtl",
            summary=f"battery {sample.battery_pct:.0f}% is below the mission's {floor:g}%: returning home",
        )  # fmt: skip
        self.control.rtl(by="failsafe")


__all__ = ["TelemetryFailsafes"]
