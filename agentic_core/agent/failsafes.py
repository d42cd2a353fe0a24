"""Failsafes on telemetry: the mission's limits act on the vehicle's own telemetry samples — battery below
``min_battery_pct``, wind above ``max_wind_mps``, GPS without a 3D fix, ``max_flight_time_s`` since take-off
passed, no sample for ``link_loss_s`` (PX4's COM_DL_LOSS_T) — each in the air, each once. No scene or reasoner is
involved. The first to fire ends the mission through the control port (as an operator's stop would, ``by:
failsafe``) with the mission's ``failsafe_action`` (or the failsafe's own in ``failsafe_actions``): ``rtl`` by
default, ``land`` or ``hold``; every one is a ``failsafe`` event on the bus. The vehicle's own failsafes (its
STATUSTEXTs) are ``failsafe`` events too, ``by: vehicle``.

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

import re
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from flight.vehicle import VehicleClient

from ..contracts import TelemetrySample
from ..contracts.policy_graph import FailsafeAction, FailsafeKind, Limits
from .control import ControlPort
from .ports import Publish

POLL_S = 0.25
"""How often the watch thread looks for a silent link and the vehicle's failsafe texts (wall seconds)."""
GPS_3D_FIX = 3
DOING = {"rtl": "returning home", "land": "landing", "hold": "holding"}

VEHICLE_FAILSAFE = re.compile(
    r"geofence|battery (low|critical)|(low|critical|emergency) battery|data link lost|connection to .* lost|"
    r"gps lost|no position|failsafe|critical failure|motor failure",
    re.IGNORECASE,
)
"""STATUSTEXTs that say the vehicle acted on its own (ours, :mod:`flight.mavlink.failsafe`, and PX4's wording)."""
NOT_A_FAILSAFE = re.compile(
    r"^failure (injected|cleared)|^failsafe (geofence|battery_low|battery_critical|position|data_link): ", re.IGNORECASE
)
"""Texts about injected faults (the fault schedule reports those), and our vehicle's note that a failsafe already
reported could not act."""


class TelemetryFailsafes:
    """A telemetry hook (every sample) and a watch thread (:meth:`start`, :meth:`close`) that turn the mission's
    limits into one stop each; ``texts`` (optional) gives the vehicle's STATUSTEXTs heard since its last call."""

    def __init__(
        self,
        limits: Limits | None,
        control: ControlPort,
        publish: Publish,
        *,
        texts: Callable[[], Sequence[str]] | None = None,
        wall: Callable[[], float] = time.monotonic,
    ) -> None:
        self.limits = limits or Limits()
        self.control = control
        self.publish = publish
        self.texts = texts
        self.wall = wall
        self._lock = threading.Lock()
        self.fired: list[FailsafeKind] = []
        """Every failsafe that fired, in order (each at most once)."""
        self.airborne_since: float | None = None
        """The vehicle's clock at the first sample in the air (the flight time's start)."""
        self._last_wall: float | None = None
        self._in_air = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def __call__(self, sample: TelemetrySample) -> None:
        in_air = sample.armed and sample.landed_state != "on_ground"
        self._last_wall, self._in_air = self.wall(), in_air
        if not in_air:
            return
        if self.airborne_since is None:
            self.airborne_since = sample.time_s
        limits = self.limits
        floor, battery = limits.min_battery_pct, sample.battery_pct
        if floor is not None and battery is not None and battery < floor:
            self._fire("battery", f"battery {battery:.0f}% is below the mission's {floor:g}%",
                       battery_pct=battery, limit_pct=floor)  # fmt: skip
        wind, ceiling = sample.wind_mps, limits.max_wind_mps
        if ceiling is not None and wind is not None and wind > ceiling:
            self._fire("wind", f"wind {wind:.1f} m/s is above the mission's {ceiling:g} m/s",
                       wind_mps=round(wind, 2), limit_mps=ceiling)  # fmt: skip
        fix = sample.gps_fix_type
        if fix is not None and fix < GPS_3D_FIX:
            self._fire("gps", f"GPS lost its fix (fix type {fix}, {sample.gps_satellites} satellites)",
                       fix_type=fix, satellites=sample.gps_satellites)  # fmt: skip
        limit_s = limits.max_flight_time_s
        if limit_s is not None and sample.time_s - self.airborne_since > limit_s:
            self._fire("flight_time", f"{sample.time_s - self.airborne_since:.0f} s in the air is over the "
                       f"mission's {limit_s:g} s", limit_s=limit_s)  # fmt: skip

    def check(self) -> None:
        """What the watch thread does: a link silent for ``link_loss_s`` in the air, and the vehicle's texts."""
        last = self._last_wall
        silent = self.wall() - last if last is not None else 0.0
        if self._in_air and silent > self.limits.link_loss_s:
            self._fire("link", f"no telemetry for {silent:.0f} s (the mission allows {self.limits.link_loss_s:g} s)",
                       silent_s=round(silent, 1), limit_s=self.limits.link_loss_s)  # fmt: skip
        for text in self.texts() if self.texts is not None else ():
            if VEHICLE_FAILSAFE.search(text) and not NOT_A_FAILSAFE.search(text):
                self.publish("failsafe", failsafe="vehicle", by="vehicle", text=text, summary=f"the vehicle: {text}")

    def start(self) -> None:
        """Start the watch thread (``failsafe-watch``); :meth:`close` ends it."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._watch, name="failsafe-watch", daemon=True)
            self._thread.start()

    def close(self) -> None:
        """End the watch thread, reading the vehicle's last texts first. Safe to call twice."""
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(timeout=5.0)
            self.check()

    def _watch(self) -> None:
        while not self._stop.wait(POLL_S):
            try:
                self.check()
            except Exception as exc:  # a bug here must not end the watch
                self.publish("log", level="error", summary=f"failsafe watch: {type(exc).__name__}: {exc}")

    def action(self, kind: FailsafeKind) -> FailsafeAction:
        """What the failsafe ``kind`` does: its own action in the mission, else the mission's."""
        return self.limits.failsafe_actions.get(kind, self.limits.failsafe_action)

    def _fire(self, kind: FailsafeKind, why: str, **fields: Any) -> None:
        with self._lock:
            if kind in self.fired:
                return
            self.fired.append(kind)
        action = self.action(kind)
        stopping = self.control.stop_requested()
        then = f"{DOING[action]}" if stopping is None else f"the run is already stopping ({stopping})"
        self.publish("failsafe", failsafe=kind, by="agent", action=action, acted=stopping is None, **fields,
                     summary=f"{why}: {then}")  # fmt: skip
        if stopping is None:
            {"rtl": self.control.rtl, "land": self.control.land, "hold": self.control.hold}[action](by="failsafe")


class VehicleTexts:
    """The STATUSTEXTs the agent's client heard since the last call (for :class:`TelemetryFailsafes`)."""

    def __init__(self, client: Callable[[], VehicleClient | None]) -> None:
        self.client = client
        self._mark = 0

    def __call__(self) -> list[str]:
        client = self.client()
        if client is None:
            return []
        now = client.text_mark
        texts = client.texts_since(self._mark)[: max(0, now - self._mark)]
        self._mark = now
        return texts


__all__ = ["TelemetryFailsafes", "VehicleTexts"]
