"""What the vehicle does in each PX4 mode: the small state machine between MAVLink commands and the simulator.

Why: a command such as NAV_RETURN_TO_LAUNCH is not one setpoint but a sequence (climb, fly home, land), and the
mode a client sees in HEARTBEAT must follow what the aircraft is doing (AUTO_TAKEOFF becomes AUTO_LOITER, "Hold",
once the take-off altitude is reached, as in PX4). :class:`Navigator` keeps the mode, turns requests into
:class:`~flight.sim.Simulator` setpoints and advances multi-phase modes from :meth:`Navigator.update`, called once
per vehicle tick. Refusals raise :class:`CommandDenied` with a reason the vehicle reports in a STATUSTEXT.

Behaviour kept from PX4 (PX4 user guide, flight modes; not verified against PX4 source):

* Take-off climbs over the current position to the requested altitude, then switches to Hold.
* Return climbs to ``RTL_RETURN_ALT`` above home (or stays higher if already higher), flies home at that altitude,
  then lands; the simulator disarms on touchdown as PX4 does. Ours: the return altitude is capped
  :data:`FENCE_MARGIN_M` below the ceiling ``GF_MAX_VER_DIST`` (a vehicle above it
  descends to it first), so a return never breaches the fence. We did not find such a cap in the PX4 sources
  we could read (PX4 lets the geofence act on a return that climbs through it); the issue asks for it.
* Disarming in the air is refused (TEMPORARILY_REJECTED, "Disarming denied: not landed", as PX4's
  ``Commander::disarm`` and its COMMAND_ACK mapping) unless param2 is the force code 21196.
* Reposition (DO_REPOSITION) flies to the point in Hold mode.
* Position mode without sticks holds position.

* Offboard flies the latest setpoint (:mod:`flight.mavlink.offboard`); switching to it needs a setpoint received
  within ``COM_OF_LOSS_T`` (so a stream is running), and when setpoints stop for ``COM_OF_LOSS_T`` the vehicle
  switches to Hold with a STATUSTEXT (PX4's ``COM_OBL_RC_ACT`` default is Position mode, which without sticks
  holds). Arming in Offboard keeps Offboard if the stream is running.
* Mission (AUTO.MISSION) flies the uploaded plan: :mod:`flight.mavlink.mission_runner` does it through the
  :class:`MissionDriver` hooks here. Switching to Mission, or arming in it, is refused without a valid mission;
  arming in Mission starts it, as does switching to it while armed.
* The geofence (:mod:`flight.mavlink.geofence`: the parameters' cylinder and any uploaded fence areas) bounds
  every target: commands and offboard setpoints outside it are refused. So does the floor ``GF_MIN_ALT`` (ours,
  :mod:`flight.mavlink.params`): reposition and offboard position targets lower than it above home are refused
  ("Geofence: target … below the … floor"); take-off and landing are not targets in this sense.
* Offboard *velocity* setpoints are limited every tick with ``GF_PREDICT`` 1 so the vehicle stops inside the
  fence, below the ceiling and above the floor (:mod:`flight.mavlink.fence_predict`), with a STATUSTEXT at most
  once per :data:`LIMIT_NOTICE_INTERVAL_S`.

Simplifications: home is the simulator's environment home (not the arming position); there is no RTL descent
altitude or loiter before landing, and no auto-disarm when armed on the ground.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import Enum
from typing import Protocol

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_LANDED_STATE_IN_AIR,
    MAV_LANDED_STATE_LANDING,
    MAV_LANDED_STATE_ON_GROUND,
    MAV_LANDED_STATE_TAKEOFF,
    MAV_RESULT_DENIED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_WARNING,
)

from agentic_core.contracts.errors import AgenticUAVError
from flight.mavlink.fence_predict import limit_velocity
from flight.mavlink.geofence import Geofence
from flight.mavlink.offboard import OffboardSetpoint
from flight.mavlink.params import ParamStore
from flight.px4 import FlightMode
from flight.sim import Simulator

TAKEOFF_ACCEPT_M = 0.5
"""Take-off is complete within this many metres of the target altitude."""
RTL_CLIMB_ACCEPT_M = 0.5
RTL_HOME_ACCEPT_M = 1.0
MIN_TAKEOFF_ALT_M = 1.0
FENCE_MARGIN_M = 1.0
"""A return flies this far below the ceiling (as far as a geofence hold flies inside the fence)."""
MIN_GPS_SATELLITES = 6
LIMIT_NOTICE_INTERVAL_S = 1.0
"""At most one STATUSTEXT per this many simulated seconds about an offboard velocity limited at the fence."""
VELOCITY_RESEND_MPS = 0.02
"""A limited velocity is given to the controller again when it changes by more than this."""


class CommandDenied(AgenticUAVError):
    """A request the vehicle refuses, with the MAV_RESULT to answer and a reason for the STATUSTEXT."""

    def __init__(self, reason: str, result: int = MAV_RESULT_DENIED) -> None:
        super().__init__(reason)
        self.reason = reason
        self.result = result


class RtlPhase(Enum):
    CLIMB = "climb"
    RETURN = "return"
    LAND = "land"


class MissionDriver(Protocol):
    """What the navigator asks of whoever flies Mission mode (:class:`~flight.mavlink.mission_runner.MissionRunner`)."""

    @property
    def landing(self) -> bool: ...
    @property
    def taking_off(self) -> bool: ...
    def start_denial(self) -> str | None:
        """Why Mission cannot be entered now (None: it can)."""

    def start(self) -> None:
        """Mission mode was entered armed (or armed in it): fly from the current item."""

    def update(self) -> None:
        """One tick in Mission mode, armed."""

    def on_disarmed(self) -> None:
        """One tick in Mission mode, disarmed (e.g. after a mission landing)."""


class _NoMission:
    """The driver until the vehicle installs one: Mission is never available."""

    landing = False
    taking_off = False

    def start_denial(self) -> str | None:
        return "no mission"

    def start(self) -> None:
        return None

    def update(self) -> None:
        return None

    def on_disarmed(self) -> None:
        return None


class Navigator:
    """The current flight mode and the setpoints that fly it."""

    def __init__(self, sim: Simulator, params: ParamStore) -> None:
        self.sim = sim
        self.params = params
        self.mode = FlightMode.HOLD
        self.rtl_phase: RtlPhase | None = None
        self.cruise_speed_mps: float | None = None
        """Set by DO_CHANGE_SPEED; None means ``MPC_XY_CRUISE``."""
        self._takeoff_alt_m = 0.0
        self._rtl_alt_m = 0.0
        self._goto: tuple[float, float, float, float | None] | None = None
        self.offboard_setpoint: OffboardSetpoint | None = None
        self.offboard_time_s: float | None = None
        """When the last offboard setpoint came, on :attr:`clock` (None: never)."""
        self.clock: Callable[[], float] = lambda: sim.time_s
        """The clock the setpoint stream is timed on: simulated time, unless the vehicle sets its link clock (a
        client streams setpoints at real-time rates, so faster than real time a live stream would look lost)."""
        self.notify: Callable[[str, int], None] = lambda text, severity: None
        """Where the navigator reports what it did on its own (the vehicle sends a STATUSTEXT)."""
        self.fence = Geofence(params)
        """The geofence every target must lie in (the vehicle installs the uploaded fence areas)."""
        self._flown_velocity: tuple[float, float, float] | None = None
        """The (possibly limited) offboard velocity last given to the simulator."""
        self._limit_noticed_s = -math.inf
        self.mission: MissionDriver = _NoMission()
        """Flies Mission mode (the vehicle installs a :class:`~flight.mavlink.mission_runner.MissionRunner`)."""

    # -- requests ---------------------------------------------------------------------------------------------

    def arm(self, force: bool = False) -> None:
        sim = self.sim
        if sim.armed:
            return
        s = sim.state()
        if self.mode is FlightMode.MISSION and (why := self.mission.start_denial()) is not None:
            raise CommandDenied(f"Arming denied: {why}", MAV_RESULT_TEMPORARILY_REJECTED)
        if not force:
            fix = sim.gps_fix()
            if fix.fix_type < 3 or fix.satellites < MIN_GPS_SATELLITES:
                raise CommandDenied("Arming denied: no 3D GPS fix", MAV_RESULT_TEMPORARILY_REJECTED)
            if s.battery_pct / 100.0 <= self.params["BAT_LOW_THR"]:
                raise CommandDenied("Arming denied: battery low", MAV_RESULT_TEMPORARILY_REJECTED)
        if not s.landed:
            raise CommandDenied("Arming denied: not landed", MAV_RESULT_TEMPORARILY_REJECTED)
        if not sim.arm():
            raise CommandDenied("Arming denied by the vehicle", MAV_RESULT_TEMPORARILY_REJECTED)
        self.rtl_phase = None
        self._goto = None
        if self.mode is FlightMode.TAKEOFF:
            self._start_takeoff(self.params["MIS_TAKEOFF_ALT"], None)
        elif self.mode is FlightMode.OFFBOARD and self.offboard_active():
            self._fly_offboard()
        elif self.mode is FlightMode.MISSION:
            self.mission.start()
        else:
            self.mode = FlightMode.HOLD

    def disarm(self, force: bool = False) -> None:
        if not self.sim.armed:
            return
        if not self.sim.disarm(force):
            raise CommandDenied("Disarming denied: not landed", MAV_RESULT_TEMPORARILY_REJECTED)
        self.rtl_phase = None
        self._goto = None

    def takeoff(self, altitude_m: float | None, yaw_rad: float | None = None) -> None:
        """Climb to ``altitude_m`` above home (None: ``MIS_TAKEOFF_ALT``)."""
        alt = self.params["MIS_TAKEOFF_ALT"] if altitude_m is None else altitude_m
        if not math.isfinite(alt) or alt < MIN_TAKEOFF_ALT_M:
            raise CommandDenied(f"Takeoff denied: altitude {alt:.1f} m is below {MIN_TAKEOFF_ALT_M:.1f} m")
        self._check_fence_altitude(alt)
        if not self.sim.armed:
            raise CommandDenied("Takeoff denied: arm first")
        self._start_takeoff(alt, yaw_rad)

    def land(self) -> None:
        if not self.sim.armed:
            raise CommandDenied("Land denied: not armed")
        self.sim.land()
        self.mode = FlightMode.LAND
        self.rtl_phase = None
        self._goto = None

    def return_to_launch(self) -> None:
        s = self.sim.state()
        if not self.sim.armed or s.landed:
            raise CommandDenied("Return denied: not flying")
        self.mode = FlightMode.RTL
        self._rtl_alt_m = self.return_altitude(s.alt_agl_m)
        self.rtl_phase = RtlPhase.CLIMB
        self._fly(s.north_m, s.east_m, -self._rtl_alt_m, None)

    def return_altitude(self, alt_m: float) -> float:
        """The altitude a return from ``alt_m`` above home flies home at: ``RTL_RETURN_ALT`` or higher if already
        higher, but never above the ceiling less the fence margin (the module docstring)."""
        target = max(self.params["RTL_RETURN_ALT"], alt_m)
        ceiling = self.params["GF_MAX_VER_DIST"]
        if ceiling > 0:
            target = min(target, max(ceiling - FENCE_MARGIN_M, 0.5 * ceiling))
        return target

    def hold(self, mode: FlightMode = FlightMode.HOLD) -> None:
        """Hold the current position (Hold or Position mode)."""
        self.mode = mode
        self.rtl_phase = None
        self._goto = None
        if self.sim.armed:
            self.sim.hold()

    def set_mode(self, mode: FlightMode) -> None:
        """Switch to ``mode`` (DO_SET_MODE). Disarmed, only the label changes (Takeoff then takes off on arming)."""
        if mode is FlightMode.MISSION and (why := self.mission.start_denial()) is not None:
            raise CommandDenied(f"Mode change denied: {why}")
        if mode is FlightMode.OFFBOARD and not self.offboard_active():
            raise CommandDenied("Mode change denied: offboard needs a setpoint stream first")
        if mode is self.mode and not (mode in (FlightMode.HOLD, FlightMode.POSITION) and self._goto is not None):
            return  # Hold asked while a reposition flies in Hold: stop there (below), as a pilot asking Hold means
        if not self.sim.armed:
            self.mode = mode
            self.rtl_phase = None
            return
        if mode in (FlightMode.HOLD, FlightMode.POSITION):
            self.hold(mode)
        elif mode is FlightMode.LAND:
            self.land()
        elif mode is FlightMode.RTL:
            self.return_to_launch()
        elif mode is FlightMode.OFFBOARD:
            self.rtl_phase = None
            self._fly_offboard()
        elif mode is FlightMode.MISSION:
            self.mode = mode
            self.rtl_phase = None
            self._goto = None
            self.mission.start()
        else:  # TAKEOFF
            self.takeoff(None)

    # -- offboard ---------------------------------------------------------------------------------------------

    def offboard_active(self) -> bool:
        """True if a flyable setpoint has arrived and setpoint messages keep coming (within ``COM_OF_LOSS_T``)."""
        t = self.offboard_time_s
        return self.offboard_setpoint is not None and t is not None and self.clock() - t <= self.params["COM_OF_LOSS_T"]

    def offboard_heard(self) -> None:
        """A setpoint message arrived, flyable or not: the stream is alive (the last flyable setpoint is kept)."""
        self.offboard_time_s = self.clock()

    def offboard_target(self, setpoint: OffboardSetpoint) -> None:
        """Record a setpoint (SET_POSITION_TARGET_*); flown at once in Offboard. Positions outside the fence raise."""
        self.offboard_heard()
        if setpoint.position is not None:
            north, east, down = setpoint.position
            self._check_fence(north, east, -down)
            self.check_floor(-down)
        self.offboard_setpoint = setpoint
        if self.mode is FlightMode.OFFBOARD and self.sim.armed:
            self._fly_offboard()

    def _fly_offboard(self) -> None:
        sp = self.offboard_setpoint
        self.mode = FlightMode.OFFBOARD
        self._goto = None
        if sp is None or not self.sim.armed:
            return
        self._flown_velocity = None
        if sp.position is not None:
            self.sim.goto(*sp.position, sp.yaw_rad, None)
        elif sp.velocity is not None:
            self._fly_velocity(sp.velocity, sp.yaw_rad)

    def _fly_velocity(self, velocity: tuple[float, float, float], yaw_rad: float | None) -> None:
        """Fly ``velocity``, limited at the fence when ``GF_PREDICT`` is 1; tell the controller only on a change."""
        vn, ve, vd = velocity
        if self.params.values["GF_PREDICT"] == 1:
            t = self.sim.truth()
            lim = limit_velocity(self.fence, t.north_m, t.east_m, t.alt_agl_m, vn, ve, vd)
            vn, ve, vd = lim.vn, lim.ve, lim.vd
            now = self.sim.time_s
            if lim.limited and now - self._limit_noticed_s >= LIMIT_NOTICE_INTERVAL_S:
                self._limit_noticed_s = now
                self.notify("Geofence: offboard velocity limited to stop at the fence", MAV_SEVERITY_WARNING)
        flown = self._flown_velocity
        if flown is not None and max(abs(vn - flown[0]), abs(ve - flown[1]), abs(vd - flown[2])) < VELOCITY_RESEND_MPS:
            return
        self._flown_velocity = (vn, ve, vd)
        self.sim.set_velocity(vn, ve, vd, yaw_rad)

    def hold_at(self, north_m: float, east_m: float, down_m: float) -> None:
        """Hold at a NED point (failsafes), without the fence check."""
        self.mode = FlightMode.HOLD
        self.rtl_phase = None
        if self.sim.armed:
            self._fly(north_m, east_m, down_m, None)

    def cut_motors(self) -> None:
        """Flight termination: stop the motors wherever the vehicle is (it falls)."""
        self.sim.disarm(force=True)
        self.rtl_phase = None
        self._goto = None

    def reposition(
        self, north_m: float, east_m: float, down_m: float, yaw_rad: float | None, speed: float | None
    ) -> None:
        """Fly to a NED point (relative to home) in Hold mode, within the geofence."""
        if not self.sim.armed or self.sim.state().landed:
            raise CommandDenied("Reposition denied: not flying")
        self._check_fence(north_m, east_m, -down_m)
        self.check_floor(-down_m)
        if speed is not None and speed > 0:
            self.cruise_speed_mps = speed
        self.mode = FlightMode.HOLD
        self.rtl_phase = None
        self._fly(north_m, east_m, down_m, yaw_rad)

    def fly_leg(self, north_m: float, east_m: float, down_m: float, yaw_rad: float | None = None) -> None:
        """Fly to a NED point at the cruise speed, in the current mode (mission legs, checked when uploaded)."""
        self._fly(north_m, east_m, down_m, yaw_rad)

    def change_speed(self, speed_mps: float) -> None:
        """Set the horizontal cruise speed, also for a go-to under way."""
        if not math.isfinite(speed_mps) or speed_mps <= 0:
            raise CommandDenied("Speed change denied: speed must be positive")
        self.cruise_speed_mps = speed_mps
        if self._goto is not None and self.sim.armed:
            self._fly(*self._goto)

    # -- per tick ---------------------------------------------------------------------------------------------

    def update(self) -> None:
        """Advance Takeoff, Return and Mission; called once per vehicle tick after the simulator has stepped."""
        sim = self.sim
        if not sim.armed:
            self.rtl_phase = None
            self._goto = None
            if self.mode is FlightMode.MISSION:
                self.mission.on_disarmed()
            return
        if self.mode is FlightMode.MISSION:
            self.mission.update()
            return
        if self.mode is FlightMode.OFFBOARD:
            if not self.offboard_active():
                self.hold()
                self.notify("Offboard setpoints lost: holding", MAV_SEVERITY_CRITICAL)
            elif (sp := self.offboard_setpoint) is not None and sp.velocity is not None:
                self._fly_velocity(sp.velocity, sp.yaw_rad)
        elif self.mode is FlightMode.TAKEOFF:
            # sim.truth(), not sim.state(): the same values, without building a snapshot every tick
            if abs(sim.truth().alt_agl_m - self._takeoff_alt_m) < TAKEOFF_ACCEPT_M:
                self.mode = FlightMode.HOLD
        elif self.mode is FlightMode.RTL and self.rtl_phase is not None:
            s = sim.truth()
            if self.rtl_phase is RtlPhase.CLIMB and abs(s.alt_agl_m - self._rtl_alt_m) < RTL_CLIMB_ACCEPT_M:
                self.rtl_phase = RtlPhase.RETURN
                self._fly(0.0, 0.0, -self._rtl_alt_m, None)
            elif (
                self.rtl_phase is RtlPhase.RETURN
                and math.hypot(s.north_m, s.east_m) < RTL_HOME_ACCEPT_M
                and math.hypot(s.vn_mps, s.ve_mps) < 0.5
            ):
                self.rtl_phase = RtlPhase.LAND
                self._goto = None
                sim.land()

    def landed_state(self) -> int:
        """MAV_LANDED_STATE for EXTENDED_SYS_STATE."""
        if not self.sim.armed:
            return int(MAV_LANDED_STATE_ON_GROUND)
        in_mission = self.mode is FlightMode.MISSION
        landing = (
            self.mode is FlightMode.LAND or self.rtl_phase is RtlPhase.LAND or (in_mission and self.mission.landing)
        )
        if landing:
            return int(MAV_LANDED_STATE_LANDING)
        if self.mode is FlightMode.TAKEOFF or (in_mission and self.mission.taking_off):
            return int(MAV_LANDED_STATE_TAKEOFF)
        return int(MAV_LANDED_STATE_ON_GROUND if self.sim.truth().on_ground else MAV_LANDED_STATE_IN_AIR)

    # -- helpers ----------------------------------------------------------------------------------------------

    def _start_takeoff(self, alt_m: float, yaw_rad: float | None) -> None:
        s = self.sim.state()
        self._takeoff_alt_m = alt_m
        self.mode = FlightMode.TAKEOFF
        self.rtl_phase = None
        self._goto = None
        self.sim.goto(s.north_m, s.east_m, -alt_m, yaw_rad, None)

    def _fly(self, north_m: float, east_m: float, down_m: float, yaw_rad: float | None) -> None:
        self._goto = (north_m, east_m, down_m, yaw_rad)
        speed = self.cruise_speed_mps if self.cruise_speed_mps is not None else self.params["MPC_XY_CRUISE"]
        self.sim.goto(north_m, east_m, down_m, yaw_rad, speed)

    def _check_fence_altitude(self, alt_m: float) -> None:
        max_v = self.params["GF_MAX_VER_DIST"]
        if max_v > 0 and alt_m > max_v:
            raise CommandDenied(f"Geofence: {alt_m:.1f} m is above the {max_v:.0f} m ceiling")

    def check_floor(self, alt_m: float) -> None:
        """Refuse a target ``alt_m`` above home lower than the floor ``GF_MIN_ALT`` (0: no floor)."""
        floor = self.params.values["GF_MIN_ALT"]
        if floor > 0 and not alt_m >= floor:
            raise CommandDenied(f"Geofence: target {alt_m:.1f} m is below the {floor:.1f} m floor")

    def _check_fence(self, north_m: float, east_m: float, alt_m: float) -> None:
        why = self.fence.violation(north_m, east_m, alt_m)
        if why is not None:
            raise CommandDenied(f"Geofence: target {why}")
