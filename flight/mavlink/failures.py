"""MAV_CMD_INJECT_FAILURE on the simulated vehicle: a low or flat battery, GPS loss, link loss, a motor off.

Why: the vehicle's own failsafes (:mod:`flight.mavlink.failsafe`) and an agent's reaction to trouble can only be
tested if trouble can be made on demand, the way PX4 SITL makes it. :class:`FailureInjector` answers the command
and applies each failure to the simulator or the link; the vehicle's failsafes then act on what they observe, as
they would on a real fault. Every failure injected or cleared, and every reaction here, goes out as a STATUSTEXT.

Facts relied on (MAVLink ``common.xml`` through pymavlink; PX4 user guide, "System Failure Injection"; PX4's
``BatterySimulator.cpp``, read in the PX4-Autopilot repository):

* MAV_CMD_INJECT_FAILURE 420: param1 FAILURE_UNIT, param2 FAILURE_TYPE, param3 instance (0: all).
  FAILURE_UNIT: SENSOR_GPS 4, SYSTEM_BATTERY 100, SYSTEM_MOTOR 101, SYSTEM_MAVLINK_SIGNAL 105 (the others exist
  and are answered UNSUPPORTED here). FAILURE_TYPE: OK 0, OFF 1, STUCK 2, GARBAGE 3, WRONG 4, SLOW 5, DELAYED 6,
  INTERMITTENT 7.
* PX4 honours the command only with ``SYS_FAILURE_EN`` 1 (default 0); we answer DENIED otherwise, with a
  STATUSTEXT. A failure combination PX4 does not implement is answered UNSUPPORTED, as PX4 does; values that are
  not a unit or type at all (NaN, fractions, numbers outside the enums) are DENIED.
* PX4's simulated battery knows only OFF (it reports the empty voltage) and OK, for instance 0. Ours, with a
  documented mapping since PX4 has no "low": **SLOW = low** (the charge reads just under ``BAT_LOW_THR``: the
  vehicle returns), **OFF = critical** (just under ``BAT_CRIT_THR``: it lands); OK restores the true reading.
  And **WRONG = a level** (ours alone; PX4 answers it UNSUPPORTED): param4 is the percentage the battery reads
  from now on, 0 to 100 (it still drains below it; the vehicle's own thresholds then act on what it reads), so
  a schedule can rehearse "the battery drops to 18 %".
* Motors are numbered from 1 as in PX4's quad X (1 front right, 2 aft left, 3 front left, 4 aft right); instance
  0 is every motor.

What each failure does here (ours where PX4 leaves it to the simulator):

* GPS OFF: the GPS reports no fix (GPS_RAW_INT fix_type 0, no satellites); arming is refused; in flight the
  position failsafe lands where the vehicle is (:mod:`flight.mavlink.failsafe`: PX4's "Descend" without RC).
  Position streams carry on from the flight model (PX4's estimator would dead-reckon for a while).
* MAVLINK_SIGNAL OFF: the vehicle neither reads nor sends anything on its link, so the data-link failsafe fires
  after ``COM_DL_LOSS_T``. The one message still read is MAV_CMD_INJECT_FAILURE for this unit with OK (PX4 would
  be restored from its shell, which is not the link); :meth:`MavlinkVehicle.inject_failure` restores it in process.
* MOTOR OFF: the motor's output is held at zero (:meth:`flight.sim.Simulator.fail_motor`). The F450 cannot fly on
  three motors: it spins and falls. Like PX4's failure detector we report an attitude failure once the tilt passes
  :data:`ATTITUDE_FAILURE_RAD` (PX4's ``FD_FAIL_R``/``FD_FAIL_P`` default of 60°; PX4 terminates only with the
  flight-termination circuit breaker off, which is not its default), and the vehicle disarms on impact.
* Failures are not part of a vehicle snapshot; restoring one clears them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    FAILURE_TYPE_OFF,
    FAILURE_TYPE_OK,
    FAILURE_TYPE_SLOW,
    FAILURE_TYPE_WRONG,
    FAILURE_UNIT_SENSOR_GPS,
    FAILURE_UNIT_SYSTEM_BATTERY,
    FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL,
    FAILURE_UNIT_SYSTEM_MOTOR,
    MAV_RESULT_DENIED,
    MAV_RESULT_UNSUPPORTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
)

from flight.mavlink.navigator import CommandDenied, Navigator

ATTITUDE_FAILURE_RAD = math.radians(60.0)
BATTERY_BELOW_THRESHOLD = 0.005
"""An injected battery level reads this far (as a fraction of charge) under its threshold."""
MOTOR_COUNT = 4

_UNITS = frozenset(mavlink2.enums["FAILURE_UNIT"]) - {max(mavlink2.enums["FAILURE_UNIT"])}
_TYPES = frozenset(mavlink2.enums["FAILURE_TYPE"]) - {max(mavlink2.enums["FAILURE_TYPE"])}
"""The enums' values (pymavlink adds an ``_ENUM_END`` entry, the largest, which is not one)."""

Notify = Callable[[str, int], None]


@dataclass(slots=True)
class FailureState:
    """The failures in force."""

    battery: int | None = None
    """FAILURE_TYPE_SLOW (low), FAILURE_TYPE_OFF (critical) or FAILURE_TYPE_WRONG (a level), None when healthy."""
    gps_off: bool = False
    link_off: bool = False
    motors_off: set[int] = field(default_factory=set)
    """Motor numbers, 1..4."""


class FailureInjector:
    """Applies MAV_CMD_INJECT_FAILURE to the navigator's simulator; :meth:`update` runs once per tick."""

    def __init__(self, navigator: Navigator, notify: Notify) -> None:
        self.navigator = navigator
        self.notify = notify
        self.state = FailureState()
        self._airborne_since_motor_failure = False
        self._attitude_reported = False

    @property
    def link_off(self) -> bool:
        return self.state.link_off

    @property
    def active(self) -> list[str]:
        """The failures in force, as words (for logs and tests)."""
        st = self.state
        out = []
        if st.battery is not None:
            out.append(
                {FAILURE_TYPE_SLOW: "battery low", FAILURE_TYPE_WRONG: "battery level"}.get(
                    st.battery, "battery critical"
                )
            )
        if st.gps_off:
            out.append("gps off")
        if st.link_off:
            out.append("mavlink signal off")
        out.extend(f"motor {n} off" for n in sorted(st.motors_off))
        return out

    def inject(
        self, unit: float, failure_type: float, instance: float, *, value: float = math.nan, enabled: bool | None = None
    ) -> None:
        """Carry out MAV_CMD_INJECT_FAILURE; raises :class:`CommandDenied` (DENIED or UNSUPPORTED) with the reason.
        ``value`` is param4 (a battery WRONG failure's level, percent); ``enabled`` None reads ``SYS_FAILURE_EN``."""
        if enabled is None:
            enabled = self.navigator.params.values["SYS_FAILURE_EN"] == 1
        if not enabled:
            raise CommandDenied("Failure injection disabled: set SYS_FAILURE_EN to 1", MAV_RESULT_DENIED)
        u, t, i = _whole(unit, "unit"), _whole(failure_type, "type"), _whole(instance, "instance")
        if u not in _UNITS:
            raise CommandDenied(f"Failure injection denied: no failure unit {u}", MAV_RESULT_DENIED)
        if t not in _TYPES:
            raise CommandDenied(f"Failure injection denied: no failure type {t}", MAV_RESULT_DENIED)
        battery = u == FAILURE_UNIT_SYSTEM_BATTERY and i == 0
        if battery and t == FAILURE_TYPE_WRONG:
            self._battery_level(value)
        elif battery and t in (FAILURE_TYPE_OK, FAILURE_TYPE_SLOW, FAILURE_TYPE_OFF):
            self._battery(t)
        elif u == FAILURE_UNIT_SENSOR_GPS and t in (FAILURE_TYPE_OK, FAILURE_TYPE_OFF) and i in (0, 1):
            self._gps(t == FAILURE_TYPE_OFF)
        elif u == FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL and t in (FAILURE_TYPE_OK, FAILURE_TYPE_OFF) and i == 0:
            self._link(t == FAILURE_TYPE_OFF)
        elif u == FAILURE_UNIT_SYSTEM_MOTOR and t in (FAILURE_TYPE_OK, FAILURE_TYPE_OFF) and 0 <= i <= MOTOR_COUNT:
            self._motors(range(1, MOTOR_COUNT + 1) if i == 0 else (i,), t == FAILURE_TYPE_OFF)
        else:
            raise CommandDenied(
                f"Failure injection unsupported: unit {u} type {t} instance {i}", MAV_RESULT_UNSUPPORTED
            )

    def clear(self) -> None:
        """Every failure cleared, silently (a snapshot was restored: the simulator is a fresh one)."""
        self.state = FailureState()
        self._airborne_since_motor_failure = self._attitude_reported = False

    # -- the failures -----------------------------------------------------------------------------------------

    def _battery(self, failure_type: int) -> None:
        battery = self.navigator.sim.battery
        params = self.navigator.params.values
        if failure_type == FAILURE_TYPE_OK:
            self.state.battery, battery.soc_cap = None, None
            self.notify("Failure cleared: battery reads true", MAV_SEVERITY_INFO)
            return
        low = failure_type == FAILURE_TYPE_SLOW
        threshold = params["BAT_LOW_THR"] if low else params["BAT_CRIT_THR"]
        self.state.battery = failure_type
        battery.soc_cap = max(0.0, threshold - BATTERY_BELOW_THRESHOLD)
        self.notify(f"Failure injected: battery {'low' if low else 'critical'}", MAV_SEVERITY_CRITICAL)

    def _battery_level(self, percent: float) -> None:
        if not (math.isfinite(percent) and 0.0 <= percent <= 100.0):
            raise CommandDenied(
                f"Failure injection denied: battery level {percent!r} is not 0 to 100 percent", MAV_RESULT_DENIED
            )
        self.state.battery = FAILURE_TYPE_WRONG
        self.navigator.sim.battery.soc_cap = percent / 100.0
        self.notify(f"Failure injected: battery reads {percent:g}%", MAV_SEVERITY_CRITICAL)

    def _gps(self, off: bool) -> None:
        self.state.gps_off = self.navigator.sim.gps_lost = off
        self.notify("Failure injected: GPS off" if off else "Failure cleared: GPS", _severity(off))

    def _link(self, off: bool) -> None:
        if not off:
            self.state.link_off = False
            self.notify("Failure cleared: MAVLink signal", MAV_SEVERITY_INFO)
            return
        self.notify("Failure injected: MAVLink signal off", MAV_SEVERITY_CRITICAL)
        self.state.link_off = True  # after the text, which then still goes out

    def _motors(self, numbers: range | tuple[int, ...], off: bool) -> None:
        sim = self.navigator.sim
        for n in numbers:
            sim.fail_motor(n - 1, off)
            if off:
                self.state.motors_off.add(n)
            else:
                self.state.motors_off.discard(n)
        which = "every motor" if len(numbers) > 1 else f"motor {numbers[0]}"
        self.notify(f"Failure injected: {which} off" if off else f"Failure cleared: {which}", _severity(off))
        if not self.state.motors_off:
            self._airborne_since_motor_failure = self._attitude_reported = False

    # -- per tick ---------------------------------------------------------------------------------------------

    def update(self) -> None:
        """The vehicle's reaction to a motor failure: report the attitude failure, disarm on impact."""
        if not self.state.motors_off:
            return
        sim = self.navigator.sim
        if not sim.armed:
            return
        t = sim.truth()
        if not t.on_ground:
            self._airborne_since_motor_failure = True
            tilted = abs(t.roll_rad) > ATTITUDE_FAILURE_RAD or abs(t.pitch_rad) > ATTITUDE_FAILURE_RAD
            if tilted and not self._attitude_reported:
                self._attitude_reported = True
                self.notify("Critical failure detected: attitude (motor off)", MAV_SEVERITY_CRITICAL)
        elif self._airborne_since_motor_failure:
            self.navigator.cut_motors()
            self.notify("Motor failure: impact, disarmed", MAV_SEVERITY_CRITICAL)
            self._airborne_since_motor_failure = False


def _whole(x: float, what: str) -> int:
    if not math.isfinite(x) or x != int(x) or not 0 <= x <= 0xFFFF:
        raise CommandDenied(f"Failure injection denied: {what} {x!r} is not a whole number", MAV_RESULT_DENIED)
    return int(x)


def _severity(off: bool) -> int:
    return int(MAV_SEVERITY_CRITICAL if off else MAV_SEVERITY_INFO)
