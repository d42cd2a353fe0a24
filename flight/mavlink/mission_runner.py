"""Mission mode (PX4 AUTO.MISSION): flying the stored flight plan item by item, and the commands that steer it.

Why: a mission is the one way a ground station hands the vehicle a whole flight at once; the vehicle must fly it
without further help and say where it is (MISSION_CURRENT, MISSION_ITEM_REACHED). :class:`MissionRunner` is the
navigator's :class:`~flight.mavlink.navigator.MissionDriver`: the navigator calls it once per tick in Mission mode
and it flies through the navigator (:meth:`~flight.mavlink.navigator.Navigator.fly_leg`) and the simulator. It also
checks a plan before it may fly (:meth:`MissionRunner.validate`) and answers MAV_CMD_MISSION_START and
MAV_CMD_DO_SET_MISSION_CURRENT (:func:`mission_command`).

Behaviour kept from PX4 (PX4 user guide, "Mission Mode (Multicopter)"; ``Commander.cpp`` for MISSION_START,
``MissionFeasibilityChecker.cpp`` for the fence check, read in the PX4-Autopilot repository; MAVLink ``common.xml``
for the item parameters):

* A plan with an item outside the geofence is stored (its upload is ACCEPTED) but not valid: the STATUSTEXT
  "Geofence violation for waypoint N" (N counted from 1) goes out, MISSION_CURRENT reports
  MISSION_STATE_NO_MISSION, and Mission mode cannot be entered. MISSION_START without a valid plan is DENIED with
  "Mission start denied! No valid mission"; its param1 (first item) must be -1..count-1 (otherwise DENIED); it
  switches to Mission and arms (TEMPORARILY_REJECTED with "Mission start denied" when arming fails).
* Likewise a plan with a waypoint lower than the floor ``GF_MIN_ALT`` ("Waypoint N is below the … floor"; ours:
  PX4 has no floor); take-off and landing items are exempt.
* Landed, the mission starts with a take-off: a NAV_TAKEOFF item climbs over the current position; any other first
  item is preceded by a climb to ``MIS_TAKEOFF_ALT``. Flying, a NAV_TAKEOFF item is a waypoint.
* NAV_WAYPOINT: reached within param2 metres (default :data:`DEFAULT_ACCEPT_M`) and :data:`ALT_ACCEPT_M`, then
  held for param1 seconds. NAV_LOITER_TIME: held param1 seconds. NAV_LOITER_UNLIM: held until the current item
  changes. NAV_LAND: flown to (unless latitude and longitude are 0: here), then landed; the vehicle disarms on
  touchdown. NAV_RETURN_TO_LAUNCH hands over to Return mode. An item with autocontinue 0 is held once reached.
* DO_CHANGE_SPEED (param1 0 or 1: horizontal; param2 m/s, -1 unchanged, -2 default), DO_JUMP (param1 target,
  param2 repeats), NAV_DELAY / CONDITION_DELAY (param1 seconds), DO_GRIPPER (param2 RELEASE 0) and DO_SET_SERVO
  (PWM ≥ :data:`~flight.mavlink.commands.PAYLOAD_RELEASE_PWM` releases the payload) are carried out; the other
  accepted items (camera, mount, ROI, ...) are passed over.
* MISSION_ITEM_REACHED goes out for each item done; after the last one the vehicle switches to Hold
  (STATUSTEXT "Mission finished, loitering"), also when it has landed ("Mission finished, landed"): PX4 switches
  to Hold when a mission is finished or cleared since PX4-Autopilot PR #20564 (in 1.14).
  Entering Mission with the plan finished holds. Setting the current item (MISSION_SET_CURRENT or
  DO_SET_MISSION_CURRENT, out of range FAILED) flies to it at once in Mission mode and clears "finished".
* MISSION_CURRENT: ``total`` is the item count (UINT16_MAX without a plan); ``mission_state`` NO_MISSION (none or
  not valid), COMPLETE, ACTIVE (in Mission mode), PAUSED (left mid-way), NOT_STARTED; ``mission_mode`` 1 in
  Mission, 2 otherwise.

Ours: the acceptance values :data:`DEFAULT_ACCEPT_M` and :data:`ALT_ACCEPT_M`; a DO_JUMP to an item that does not
exist makes the plan invalid; "reached" is reported for the passed-over items too, one message each.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from enum import Enum
from typing import NamedTuple

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_CMD_CONDITION_DELAY,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_JUMP,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_MISSION_START,
    MAV_CMD_NAV_DELAY,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LOITER_TIME,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_VTOL_LAND,
    MAV_CMD_NAV_VTOL_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_MISSION_TYPE_MISSION,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
    MISSION_STATE_ACTIVE,
    MISSION_STATE_COMPLETE,
    MISSION_STATE_NO_MISSION,
    MISSION_STATE_NOT_STARTED,
    MISSION_STATE_PAUSED,
)

from agentic_core.contracts.geodesy import local_offset
from flight.mavlink.commands import GRIPPER_ACTION_RELEASE, PAYLOAD_RELEASE_PWM, CommandOutcome, CommandRequest
from flight.mavlink.mission import MissionStore
from flight.mavlink.mission_items import StoredItem
from flight.mavlink.navigator import TAKEOFF_ACCEPT_M, CommandDenied, Navigator
from flight.px4 import FlightMode

DEFAULT_ACCEPT_M = 2.0
"""Horizontal acceptance radius of an item that gives none (ours; PX4's is ``NAV_ACC_RAD``)."""
ALT_ACCEPT_M = 1.0
"""Vertical acceptance of a waypoint (ours; PX4's is ``NAV_MC_ALT_RAD``)."""
MAX_ITEMS_PER_TICK = 64
"""Non-navigation items carried out in one tick at most (a DO_JUMP loop cannot stall the vehicle)."""
UINT16_MAX = 0xFFFF
MISSION_MODE_ACTIVE = 1
MISSION_MODE_SUSPENDED = 2

TAKEOFF_COMMANDS = frozenset({MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_VTOL_TAKEOFF})
LAND_COMMANDS = frozenset({MAV_CMD_NAV_LAND, MAV_CMD_NAV_VTOL_LAND})
DELAY_COMMANDS = frozenset({MAV_CMD_NAV_DELAY, MAV_CMD_CONDITION_DELAY})


class Phase(Enum):
    IDLE = "idle"
    """Nothing under way: not started, paused, or done."""
    TAKEOFF = "takeoff"
    GOTO = "goto"
    WAIT = "wait"
    """Holding for a time (hold time, loiter time, delay)."""
    HOLD = "hold"
    """Holding until told otherwise (loiter unlimited, autocontinue 0)."""
    LAND = "land"


class MissionStatus(NamedTuple):
    """What MISSION_CURRENT reports. A named tuple: one is built and compared every vehicle tick."""

    seq: int
    total: int
    state: int
    mode: int


class MissionRunner:
    """Flies the flight plan of ``store`` through ``nav``; ``notify`` sends STATUSTEXTs."""

    def __init__(self, nav: Navigator, store: MissionStore, notify: Callable[[str, int], None]) -> None:
        self.nav = nav
        self.store = store
        self.notify = notify
        self.valid = False
        self.invalid_reason: str | None = "no mission"
        self.reached = -1
        """The last item reached (-1: none since the plan was stored)."""
        self.finished = False
        self.reached_events: list[int] = []
        """Items reached since the vehicle last collected them (it sends MISSION_ITEM_REACHED for each)."""
        self.announce = False
        """MISSION_CURRENT must go out even if nothing changed (the current item was set)."""
        self._phase = Phase.IDLE
        self._target: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._accept_m = DEFAULT_ACCEPT_M
        self._wait_until = 0.0
        self._climb_alt_m = 0.0
        self._then_item = False
        """After the climb: True starts the current item (auto take-off), False flies on to the take-off item's
        position."""
        self._land_after = False
        self._jumps: dict[int, int] = {}

    # -- the navigator's hooks (MissionDriver) ----------------------------------------------------------------

    @property
    def landing(self) -> bool:
        return self._phase is Phase.LAND

    @property
    def taking_off(self) -> bool:
        return self._phase is Phase.TAKEOFF

    @property
    def items(self) -> tuple[StoredItem, ...]:
        return self.store.items(MAV_MISSION_TYPE_MISSION)

    def start_denial(self) -> str | None:
        return self.validate()

    def start(self) -> None:
        if self.finished:
            self.nav.hold()
            return
        if self.nav.sim.state().landed:
            item = self.items[self.store.current_seq]
            if item.command not in TAKEOFF_COMMANDS:
                self._climb(self.nav.params["MIS_TAKEOFF_ALT"], then_item=True)
                return
        self._begin(self.store.current_seq)

    def update(self) -> None:
        phase = self._phase
        s = self.nav.sim.state()
        if phase is Phase.IDLE:
            self._begin(self.store.current_seq)
        elif phase is Phase.TAKEOFF:
            if abs(s.alt_agl_m - self._climb_alt_m) < TAKEOFF_ACCEPT_M:
                if self._then_item:
                    self._begin(self.store.current_seq)
                else:
                    self._goto(*self._target)
        elif phase is Phase.GOTO:
            north, east, down = self._target
            if (
                math.hypot(s.north_m - north, s.east_m - east) <= self._accept_m
                and abs(s.down_m - down) <= ALT_ACCEPT_M
            ):
                self._arrived()
        elif phase is Phase.WAIT and self.nav.sim.time_s >= self._wait_until:
            self._done(self.store.current_seq)

    def on_disarmed(self) -> None:
        if self._phase is Phase.LAND:
            self._phase = Phase.IDLE
            seq = self.store.current_seq
            self._mark_reached(seq)
            if seq + 1 < len(self.items):
                self.store.current_seq = seq + 1
            else:
                self.finished = True
                self.notify("Mission finished, landed", MAV_SEVERITY_INFO)
                self.nav.hold()  # disarmed: only the label changes

    # -- plan changes and steering ----------------------------------------------------------------------------

    def validate(self) -> str | None:
        """Check the plan (PX4's feasibility check, the geofence part): None if it may fly, else why not."""
        items = self.items
        home = self.nav.sim.environment.home
        floor = self.nav.params.values["GF_MIN_ALT"]
        why: str | None = None
        if not items:
            why = "no mission"
        for i, item in enumerate(items):
            if why is not None:
                break
            if item.command == MAV_CMD_DO_JUMP and not 0 <= int(_num(item.params[0], -1)) < len(items):
                why = f"DO_JUMP at item {i + 1} has no item {int(_num(item.params[0], -1))} to jump to"
            elif item.is_position:
                here = item.x == 0 and item.y == 0 and item.command in TAKEOFF_COMMANDS | LAND_COMMANDS
                north, east = (0.0, 0.0) if here else local_offset(home.lat_deg, home.lon_deg, item.x, item.y)
                alt = self._alt_of(item)
                if self.nav.fence.violation(north, east, 0.0 if alt is None else alt) is not None:
                    why = f"Geofence violation for waypoint {i + 1}"
                elif alt is not None and item.command not in TAKEOFF_COMMANDS | LAND_COMMANDS and alt < floor:
                    why = f"Waypoint {i + 1} is below the {floor:.1f} m floor"
        self.valid, self.invalid_reason = why is None, why
        return why

    def plan_changed(self) -> None:
        """A new flight plan was stored (or cleared): start over from its current item, checked afresh."""
        self.reached, self.finished = -1, False
        self._jumps.clear()
        self._phase = Phase.IDLE
        if self.recheck() and self.nav.mode is FlightMode.MISSION and self.nav.sim.armed:
            self.start()

    def recheck(self) -> bool:
        """Check the plan again (it, or the fence, changed); an invalid plan is reported, and stops a mission
        under way (the vehicle holds). True if the plan may fly."""
        why = self.validate()
        if why is None:
            return True
        if self.items:
            self.notify(why, MAV_SEVERITY_CRITICAL)
        if self.nav.mode is FlightMode.MISSION and self.nav.sim.armed:
            self._phase = Phase.IDLE
            self.nav.hold()
        return False

    def set_current(self, seq: int, reset_jumps: bool = False) -> bool:
        """Make ``seq`` the current item (-1: keep it); in Mission mode, fly to it now. False if out of range."""
        if seq == -1:
            seq = self.store.current_seq
        if not 0 <= seq < len(self.items):
            return False
        if reset_jumps:
            self._jumps.clear()
        self.store.current_seq = seq
        self.finished = False
        self.announce = True
        self._phase = Phase.IDLE
        if self.nav.mode is FlightMode.MISSION and self.nav.sim.armed:
            self.start()
        return True

    def status(self) -> MissionStatus:
        count = len(self.items)
        active = self.nav.mode is FlightMode.MISSION
        if count == 0 or not self.valid:
            state = MISSION_STATE_NO_MISSION
        elif self.finished:
            state = MISSION_STATE_COMPLETE
        elif active:
            state = MISSION_STATE_ACTIVE
        elif self.reached >= 0:
            state = MISSION_STATE_PAUSED
        else:
            state = MISSION_STATE_NOT_STARTED
        mode = MISSION_MODE_ACTIVE if active else MISSION_MODE_SUSPENDED
        return MissionStatus(self.store.current_seq, count if count else UINT16_MAX, state, mode)

    # -- flying the items -------------------------------------------------------------------------------------

    def _begin(self, seq: int) -> None:
        """Start item ``seq``, carrying out non-navigation items at once until one that takes time."""
        items = self.items
        for _ in range(MAX_ITEMS_PER_TICK):
            if not 0 <= seq < len(items):
                self._finish()
                return
            self.store.current_seq = seq
            item = items[seq]
            if item.command == MAV_CMD_DO_JUMP:
                target, repeats = int(_num(item.params[0], -1)), int(_num(item.params[1], 0))
                done = self._jumps.get(seq, 0)
                if done < repeats and 0 <= target < len(items):
                    self._jumps[seq] = done + 1
                    seq = target
                    continue
                self._mark_reached(seq)
                seq += 1
                continue
            if item.is_position:
                self._fly_item(item)
                return
            if item.command == MAV_CMD_NAV_RETURN_TO_LAUNCH:
                self._return(seq)
                return
            if item.command in DELAY_COMMANDS:
                self._phase = Phase.WAIT
                self._wait_until = self.nav.sim.time_s + max(0.0, _num(item.params[0], 0.0))
                return
            self._do(item)
            self._mark_reached(seq)
            seq += 1
        self._phase = Phase.IDLE  # resumed on the next tick

    def _fly_item(self, item: StoredItem) -> None:
        s = self.nav.sim.state()
        here = item.x == 0 and item.y == 0 and item.command in TAKEOFF_COMMANDS | LAND_COMMANDS
        if here:
            north, east = s.north_m, s.east_m
        else:
            home = self.nav.sim.environment.home
            north, east = local_offset(home.lat_deg, home.lon_deg, item.x, item.y)
        alt = self._alt_of(item)
        down = s.down_m if alt is None or item.command in LAND_COMMANDS else -alt
        radius = item.params[1] if item.command == MAV_CMD_NAV_WAYPOINT else 0.0
        self._accept_m = radius if math.isfinite(radius) and radius > 0 else DEFAULT_ACCEPT_M
        self._land_after = item.command in LAND_COMMANDS
        self._target = (north, east, down)
        if item.command in TAKEOFF_COMMANDS and s.landed:
            minimum = self.nav.params["MIS_TAKEOFF_ALT"]
            climb = minimum if alt is None else max(alt, minimum)
            self._target = (north, east, -climb)
            self._climb(climb, then_item=False)
        elif self._land_after and math.hypot(s.north_m - north, s.east_m - east) <= self._accept_m:
            self._land()
        else:
            self._goto(north, east, down)

    def _arrived(self) -> None:
        seq = self.store.current_seq
        item = self.items[seq]
        if self._land_after:
            self._land()
            return
        if item.command == MAV_CMD_NAV_LOITER_UNLIM or not item.autocontinue:
            self._phase = Phase.HOLD
            return
        hold_s = _num(item.params[0], 0.0) if item.command in (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_LOITER_TIME) else 0.0
        if hold_s > 0:
            self._phase = Phase.WAIT
            self._wait_until = self.nav.sim.time_s + hold_s
            return
        self._done(seq)

    def _done(self, seq: int) -> None:
        self._mark_reached(seq)
        self._begin(seq + 1)

    def _finish(self) -> None:
        self.store.current_seq = max(0, len(self.items) - 1)
        self.finished = True
        self._phase = Phase.IDLE
        self.notify("Mission finished, loitering", MAV_SEVERITY_INFO)
        self.nav.hold()

    def _goto(self, north: float, east: float, down: float) -> None:
        self._phase = Phase.GOTO
        self._target = (north, east, down)
        self.nav.fly_leg(north, east, down)

    def _climb(self, alt_m: float, *, then_item: bool) -> None:
        s = self.nav.sim.state()
        self._phase = Phase.TAKEOFF
        self._climb_alt_m = alt_m
        self._then_item = then_item
        self.nav.sim.goto(s.north_m, s.east_m, -alt_m, None, None)

    def _land(self) -> None:
        self._phase = Phase.LAND
        self.nav.sim.land()

    def _return(self, seq: int) -> None:
        self._phase = Phase.IDLE
        self._mark_reached(seq)
        if seq + 1 < len(self.items):
            self.store.current_seq = seq + 1
        else:
            self.finished = True
        try:
            self.nav.return_to_launch()
        except CommandDenied as denied:
            self.notify(denied.reason, MAV_SEVERITY_CRITICAL)

    def _do(self, item: StoredItem) -> None:
        """Carry out a non-navigation item this vehicle supports; pass over the rest."""
        p1, p2 = item.params[0], item.params[1]
        if item.command == MAV_CMD_DO_CHANGE_SPEED and p1 in (0, 1):
            if p2 == -2:
                self.nav.cruise_speed_mps = None
            elif math.isfinite(p2) and p2 > 0:
                self.nav.change_speed(p2)
        elif (item.command == MAV_CMD_DO_GRIPPER and p2 == GRIPPER_ACTION_RELEASE) or (
            item.command == MAV_CMD_DO_SET_SERVO and math.isfinite(p2) and p2 >= PAYLOAD_RELEASE_PWM
        ):
            self.nav.sim.release_payload()

    def _mark_reached(self, seq: int) -> None:
        self.reached = seq
        self.reached_events.append(seq)

    def _alt_of(self, item: StoredItem) -> float | None:
        """The item's altitude above home (None when not a number)."""
        if not math.isfinite(item.z):
            return None
        return item.z if item.relative_alt else item.z - self.nav.sim.environment.home.alt_msl_m


def _num(x: float, default: float) -> float:
    return x if math.isfinite(x) else default


MISSION_COMMANDS = frozenset({MAV_CMD_MISSION_START, MAV_CMD_DO_SET_MISSION_CURRENT})
"""Commands :func:`mission_command` answers (the vehicle routes them here instead of the general handlers)."""


def mission_command(runner: MissionRunner, req: CommandRequest) -> CommandOutcome:
    """MAV_CMD_MISSION_START or MAV_CMD_DO_SET_MISSION_CURRENT: carry it out and say how it went."""
    nav = runner.nav
    if req.command == MAV_CMD_MISSION_START:
        if runner.validate() is not None:
            runner.notify("Mission start denied! No valid mission", MAV_SEVERITY_CRITICAL)
            return CommandOutcome(MAV_RESULT_DENIED)
        first = req.params[0]
        if not (math.isfinite(first) and -1 <= first < len(runner.items)):
            return CommandOutcome(MAV_RESULT_DENIED)
        try:
            nav.set_mode(FlightMode.MISSION)
            nav.arm()
        except CommandDenied as denied:
            runner.notify(denied.reason, MAV_SEVERITY_CRITICAL)
            runner.notify("Mission start denied", MAV_SEVERITY_CRITICAL)
            return CommandOutcome(MAV_RESULT_TEMPORARILY_REJECTED)
        return CommandOutcome(MAV_RESULT_ACCEPTED)
    seq, reset = req.params[0], req.params[1]
    if not (math.isfinite(seq) and seq == int(seq) and runner.set_current(int(seq), reset == 1)):
        runner.notify("Mission item not set: not in the mission", MAV_SEVERITY_CRITICAL)
        return CommandOutcome(MAV_RESULT_FAILED)
    return CommandOutcome(MAV_RESULT_ACCEPTED)
