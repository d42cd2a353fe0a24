"""Failsafes the vehicle enforces whatever its clients say: geofence (and so maximum altitude), battery, data link.

Why: an agent can be wrong, slow or cut off; the aircraft must still stay inside its fence, come home before the
battery is flat and not wander on without a ground station. :class:`Failsafes` is checked once per vehicle tick,
after the simulator has stepped, and acts through the :class:`~flight.mavlink.navigator.Navigator` with a
STATUSTEXT saying what happened and why.

Behaviour (PX4 values; see :mod:`flight.mavlink.params` for the parameters and where their values were checked):

* Geofence: a cylinder around home, ``GF_MAX_HOR_DIST`` metres in radius and ``GF_MAX_VER_DIST`` metres above it
  (0 disables either). It is also the maximum altitude: commands above it are denied by the navigator, and climbing
  through it (velocity setpoints, wind) is a breach. On a breach while flying, ``GF_ACTION`` is carried out once:
  0 none, 1 warning, 2 hold, 3 return, 4 terminate, 5 land. PX4 predicts breaches (``GF_PREDICT``) and so holds
  just inside; we detect the breach itself and hold at the nearest point 1 m inside the fence instead. The breach
  re-arms once the vehicle is back inside.
* The uploaded fence areas (polygons and circles of a fence plan, :mod:`flight.mavlink.geofence`) are part of the
  same fence: leaving an inclusion area or entering an exclusion area is a breach with the same ``GF_ACTION``; a
  hold then goes back to the last position that was inside.
* Battery (our policy, simpler than PX4's ``COM_LOW_BAT_ACT``): at or below ``BAT_LOW_THR`` of charge the vehicle
  returns; at or below ``BAT_CRIT_THR`` it lands where it is. Each level acts once per flight.
* Data link: once any peer has been heard, no valid message from any peer for ``COM_DL_LOSS_T`` seconds of
  *simulated* time while flying triggers ``NAV_DLL_ACT`` (0 disabled, 1 hold, 2 return, 3 land, 5 terminate,
  6 disarm; 4, retired in PX4, is taken as return). A message from any peer clears the loss.
* Position (GPS) loss: once the GPS reports no 3D fix while flying (an injected failure,
  :mod:`flight.mavlink.failures`), the vehicle lands where it is (PX4's failsafe without a position and without
  RC is "Descend"; we land straight down on the flight model's own position, having no estimator to lose). Once
  per loss; a fix again re-arms it.
* A failsafe never downgrades what the vehicle is already doing: a return does not interrupt a landing, a hold does
  not interrupt a return. Terminate and disarm cut the motors in the air (the aircraft falls), as in PX4.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import IntEnum

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_WARNING,
)

from flight.mavlink.navigator import CommandDenied, Navigator
from flight.px4 import FlightMode

FENCE_HOLD_MARGIN_M = 1.0
"""A geofence hold is flown this far inside the fence."""

Notify = Callable[[str, int], None]


class Action(IntEnum):
    """What a failsafe does, ordered by severity."""

    NONE = 0
    WARN = 1
    HOLD = 2
    RTL = 3
    LAND = 4
    DISARM = 5
    TERMINATE = 6


GF_ACTIONS = {0: Action.NONE, 1: Action.WARN, 2: Action.HOLD, 3: Action.RTL, 4: Action.TERMINATE, 5: Action.LAND}
"""PX4 ``GF_ACTION`` values."""
DLL_ACTIONS = {
    0: Action.NONE,
    1: Action.HOLD,
    2: Action.RTL,
    3: Action.LAND,
    4: Action.RTL,
    5: Action.TERMINATE,
    6: Action.DISARM,
}
"""PX4 ``NAV_DLL_ACT`` values (4 is retired in PX4; taken as return)."""

_ACTION_WORDS = {
    Action.NONE: "no action",
    Action.WARN: "warning only",
    Action.HOLD: "holding",
    Action.RTL: "returning",
    Action.LAND: "landing",
    Action.DISARM: "disarming",
    Action.TERMINATE: "terminating flight",
}


class Failsafes:
    """Geofence, battery and data-link failsafes, checked by :meth:`update` once per tick."""

    def __init__(self, navigator: Navigator, notify: Notify) -> None:
        self.navigator = navigator
        self.notify = notify
        self.fence_breached = False
        self.battery_level = 0
        """0 normal, 1 low (returned), 2 critical (landed); reset on the ground with a charged battery."""
        self.link_lost = False
        self.position_lost = False
        self._last_inside: tuple[float, float, float] | None = None
        """The last position (NED) found inside the fence areas, where a hold after an area breach goes."""
        self._area_breach = False
        self.triggered: list[str] = []
        """Every failsafe that acted, in order (for tests and logs)."""

    def update(self, last_rx_s: float | None, now_s: float | None = None) -> None:
        """Check everything; ``last_rx_s`` is when the last valid message came (None: none yet) and ``now_s`` the
        time now, both on the vehicle's link clock (simulated time unless given)."""
        nav = self.navigator
        sim = nav.sim
        s = sim.truth()  # not sim.state(): building that snapshot every tick costs more than all these checks
        battery_pct = sim.battery.percent
        flying = sim.armed and not s.on_ground
        if last_rx_s is not None:
            self._check_link(flying, sim.time_s if now_s is None else now_s, last_rx_s)
        if not flying:
            self.fence_breached = False
            if battery_pct / 100.0 > nav.params.values["BAT_LOW_THR"]:
                self.battery_level = 0
            return
        self._check_fence(s.north_m, s.east_m, s.alt_agl_m)
        self._check_battery(battery_pct / 100.0)
        self._check_position()

    # -- checks -----------------------------------------------------------------------------------------------

    def _check_fence(self, north_m: float, east_m: float, alt_m: float) -> None:
        params = self.navigator.params.values
        max_h, max_v = params["GF_MAX_HOR_DIST"], params["GF_MAX_VER_DIST"]
        dist = math.hypot(north_m, east_m)
        outside_h = max_h > 0 and dist > max_h
        outside_v = max_v > 0 and alt_m > max_v
        area_why = None if outside_h or outside_v else self.navigator.fence.area_violation(north_m, east_m)
        if not (outside_h or outside_v or area_why):
            self.fence_breached = False
            self._last_inside = (north_m, east_m, -alt_m)
            return
        if self.fence_breached:
            return
        self.fence_breached = True
        self._area_breach = area_why is not None
        action = GF_ACTIONS.get(int(params["GF_ACTION"]), Action.HOLD)
        if outside_h:
            where = f"{dist:.0f} m from home"
        elif outside_v:
            where = f"{alt_m:.0f} m above home"
        else:
            where = str(area_why)
        self._act("geofence", action, f"Geofence breached ({where}): {_ACTION_WORDS[action]}")

    def _check_battery(self, fraction: float) -> None:
        params = self.navigator.params.values
        if fraction <= params["BAT_CRIT_THR"] and self.battery_level < 2:
            self.battery_level = 2
            self._act("battery_critical", Action.LAND, f"Battery critical ({fraction:.0%}): landing")
        elif fraction <= params["BAT_LOW_THR"] and self.battery_level < 1:
            self.battery_level = 1
            self._act("battery_low", Action.RTL, f"Battery low ({fraction:.0%}): returning")

    def _check_position(self) -> None:
        sim = self.navigator.sim
        if not sim.gps_lost:  # the one way the simulated GPS loses its fix; gps_fix() is not built every tick
            self.position_lost = False
            return
        if self.position_lost:
            return
        self.position_lost = True
        self._act("position", Action.LAND, "GPS lost, no position: landing")

    def _check_link(self, flying: bool, now_s: float, last_rx_s: float | None) -> None:
        if last_rx_s is None:
            return
        timeout = self.navigator.params.values["COM_DL_LOSS_T"]
        silent = now_s - last_rx_s > timeout
        if not silent:
            if self.link_lost:
                self.link_lost = False
                self.notify("Data link regained", MAV_SEVERITY_INFO)
            return
        if self.link_lost or not flying:
            return
        self.link_lost = True
        action = DLL_ACTIONS.get(int(self.navigator.params["NAV_DLL_ACT"]), Action.RTL)
        self._act("data_link", action, f"Data link lost for {timeout:.0f} s: {_ACTION_WORDS[action]}")

    # -- acting -----------------------------------------------------------------------------------------------

    def _current(self) -> Action:
        mode = self.navigator.mode
        if mode is FlightMode.LAND:
            return Action.LAND
        if mode is FlightMode.RTL:
            return Action.RTL
        return Action.NONE

    def _act(self, name: str, action: Action, text: str) -> None:
        self.triggered.append(name)
        self.notify(text, MAV_SEVERITY_CRITICAL)  # PX4: a geofence warning is "a critical mavlink message"
        if action <= Action.WARN or action <= self._current():
            return
        nav = self.navigator
        try:
            if action is Action.HOLD:
                if name == "geofence":
                    nav.hold_at(*self._inside_point())
                else:
                    nav.hold()
            elif action is Action.RTL:
                nav.return_to_launch()
            elif action is Action.LAND:
                nav.land()
            else:
                nav.cut_motors()
        except CommandDenied as denied:  # e.g. touched down meanwhile
            self.notify(f"Failsafe {name}: {denied.reason}", MAV_SEVERITY_WARNING)

    def _inside_point(self) -> tuple[float, float, float]:
        """The current position pulled back inside the fence by :data:`FENCE_HOLD_MARGIN_M` (NED); after a breach
        of an uploaded fence area, the last position that was inside it."""
        if self._area_breach and self._last_inside is not None:
            return self._last_inside
        s = self.navigator.sim.state()
        params = self.navigator.params
        north, east, alt = s.north_m, s.east_m, s.alt_agl_m
        max_h, max_v = params["GF_MAX_HOR_DIST"], params["GF_MAX_VER_DIST"]
        dist = math.hypot(north, east)
        if max_h > 0 and dist > max_h - FENCE_HOLD_MARGIN_M:
            scale = max(0.0, max_h - FENCE_HOLD_MARGIN_M) / dist
            north, east = north * scale, east * scale
        if max_v > 0:
            alt = min(alt, max(max_v - FENCE_HOLD_MARGIN_M, 0.5 * max_v))
        return north, east, -alt
