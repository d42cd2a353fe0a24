"""The flight actions: arm, take off, fly to a point, orbit, hover, hold, land, return, release the payload.

Why: these are what a mission step (and the ``flight.*`` tools) ask of the aircraft. Each returns a
:class:`~flight.client.results.FlightResult` built from the COMMAND_ACK *and* the state observed afterwards:
``status`` (``ok``, ``denied``, ``timeout``, ``unsupported``, ``failed``), ``reason`` (the STATUSTEXT that came with
a refusal, or what went wrong), ``reached`` where a position or state is awaited, and the telemetry at the end.

Facts relied on (MAVLink ``common.xml`` through pymavlink's ``dialects/v20/common.py``; PX4 user guide):

* Commands: NAV_RETURN_TO_LAUNCH 20, NAV_LAND 21 (param5/6 NaN: here), NAV_TAKEOFF 22 (COMMAND_LONG param7 is the
  altitude above mean sea level in PX4), DO_ORBIT 34 (param1 radius, positive clockwise; param2 velocity; param3
  yaw behaviour; param4 orbits), DO_SET_MODE 176 (param1 base mode with CUSTOM_MODE_ENABLED 1, param2 PX4 main
  mode, param3 sub mode), DO_REPOSITION 192 (param1 ground speed, -1 default; param2 flags, CHANGE_MODE 1; param4
  yaw, NaN keep; x/y degE7; z altitude in ``frame``, NaN keep), DO_GRIPPER 211 (param1 instance, param2 RELEASE 0),
  COMPONENT_ARM_DISARM 400 (param2 21196 forces), GET_HOME_POSITION 410.
* Frame MAV_FRAME_GLOBAL_RELATIVE_ALT_INT 6: altitudes above home.
"""

from __future__ import annotations

import math
import time
from typing import Any

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_ORBIT,
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_GET_HOME_POSITION,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_RESULT_UNSUPPORTED,
)

from agentic_core.contracts.geodesy import local_offset, offset_position
from flight.client.commands import Ack
from flight.client.operations import OperationsClient
from flight.client.results import FlightResult
from flight.client.telemetry import Telemetry, TelemetryState
from flight.px4 import AutoSubMode, MainMode

FORCE_MAGIC = 21196
GRIPPER_ACTION_RELEASE = 0


class FlightActions(OperationsClient):
    """The actions that fly the vehicle."""

    async def arm(self, *, force: bool = False, timeout_s: float = 10.0) -> FlightResult:
        """Arm (pre-arm checks apply unless ``force``) and wait until the vehicle reports armed."""
        op = self._begin("arm")
        ack = await self._command(MAV_CMD_COMPONENT_ARM_DISARM, (1.0, float(FORCE_MAGIC) if force else 0.0))
        if not ack.accepted:
            return self._refused(op, ack)
        status, reason, reached = await self._fly_wait(op, lambda s: s.armed, timeout_s, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def disarm(self, *, force: bool = False, timeout_s: float = 10.0) -> FlightResult:
        """Disarm (refused in the air unless ``force``, which drops the aircraft)."""
        op = self._begin("disarm")
        ack = await self._command(MAV_CMD_COMPONENT_ARM_DISARM, (0.0, float(FORCE_MAGIC) if force else 0.0))
        if not ack.accepted:
            return self._refused(op, ack)
        status, reason, reached = await self._fly_wait(op, lambda s: not s.armed, timeout_s, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def _home_alt(self, timeout_s: float = 3.0) -> float | None:
        """Home's altitude above mean sea level: HOME_POSITION, else GLOBAL_POSITION_INT's alt − relative_alt."""

        def known(_msg: Any) -> Any:
            s = self._state
            if s.home is not None:
                return s.home[2]
            if s.alt_msl_m is not None and s.alt_m is not None:
                return s.alt_msl_m - s.alt_m
            return None

        return await self._wait(known, timeout_s)  # type: ignore[no-any-return]

    async def _home_position(self, timeout_s: float = 3.0) -> tuple[float, float, float] | None:
        if self.home is None:
            self._send_command_long(MAV_CMD_GET_HOME_POSITION, (0.0,) * 7)
        return await self._wait(lambda _m: self._state.home, timeout_s)  # type: ignore[no-any-return]

    async def takeoff(self, alt_m: float, *, timeout_s: float | None = None, tolerance_m: float = 0.6) -> FlightResult:
        """Take off to ``alt_m`` above home (armed first: see :meth:`arm`) and wait until there."""
        op = self._begin("takeoff")
        if not (math.isfinite(alt_m) and alt_m > 0):
            return self._result(op, "failed", reason=f"take-off altitude must be positive, got {alt_m}")
        home_alt = await self._home_alt()
        if home_alt is None:
            return self._result(op, "timeout", reason="no HOME_POSITION or GLOBAL_POSITION_INT to know home's altitude")
        nan = math.nan
        ack = await self._command(MAV_CMD_NAV_TAKEOFF, (0.0, 0.0, 0.0, nan, nan, nan, home_alt + alt_m))
        if not ack.accepted:
            return self._refused(op, ack)
        wait = timeout_s if timeout_s is not None else 30.0 + alt_m / 1.0

        def there(s: TelemetryState) -> bool:
            return s.alt_m is not None and abs(s.alt_m - alt_m) < tolerance_m

        status, reason, reached = await self._fly_wait(op, there, wait)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    def _distance_to(self, s: TelemetryState, lat: float, lon: float) -> float | None:
        if s.lat_deg is None or s.lon_deg is None:
            return None
        north, east = local_offset(lat, lon, s.lat_deg, s.lon_deg)
        return math.hypot(north, east)

    async def goto(
        self,
        lat: float,
        lon: float,
        alt_m: float | None = None,
        *,
        speed_mps: float | None = None,
        yaw_deg: float | None = None,
        timeout_s: float | None = None,
        acceptance_m: float = 1.5,
        alt_tolerance_m: float = 1.0,
        action: str = "goto",
    ) -> FlightResult:
        """Fly to ``lat, lon`` at ``alt_m`` above home (None: keep the altitude) with DO_REPOSITION, and wait until
        within ``acceptance_m`` horizontally and ``alt_tolerance_m`` vertically."""
        op = self._begin(action)
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            return self._result(op, "failed", reason=f"position out of range: {lat}, {lon}")
        if alt_m is not None and not math.isfinite(alt_m):
            return self._result(op, "failed", reason="altitude is not a number")
        params = (
            float(speed_mps) if speed_mps is not None and speed_mps > 0 else -1.0,
            float(MAV_DO_REPOSITION_FLAGS_CHANGE_MODE),
            0.0,
            math.nan if yaw_deg is None else math.radians(yaw_deg),  # PX4 reads param4 in radians
        )
        z = math.nan if alt_m is None else float(alt_m)
        ack = await self._command(
            MAV_CMD_DO_REPOSITION,
            params,
            frame=MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            x=round(lat * 1e7),
            y=round(lon * 1e7),
            z=z,
        )
        if not ack.accepted:
            return self._refused(op, ack)
        if timeout_s is None:
            with self._lock:
                s = self._state
                dist = self._distance_to(s, lat, lon) or 0.0
                climb = abs(alt_m - s.alt_m) if alt_m is not None and s.alt_m is not None else 0.0
            timeout_s = 30.0 + dist / 2.0 + climb

        def there(s: TelemetryState) -> bool:
            dist = self._distance_to(s, lat, lon)
            if dist is None or dist > acceptance_m:
                return False
            return alt_m is None or (s.alt_m is not None and abs(s.alt_m - alt_m) <= alt_tolerance_m)

        status, reason, reached = await self._fly_wait(op, there, timeout_s)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def goto_local(
        self, north_m: float, east_m: float, alt_m: float | None = None, **kwargs: Any
    ) -> FlightResult:
        """:meth:`goto` a point ``north_m``/``east_m`` from home (takes :meth:`goto`'s keyword options)."""
        home = await self._home_position()
        if home is None:
            op = self._begin(kwargs.get("action", "goto"))
            return self._result(op, "timeout", reason="home position unknown (no HOME_POSITION)")
        lat, lon = offset_position(home[0], home[1], north_m, east_m)
        return await self.goto(lat, lon, alt_m, **kwargs)

    async def hold(self, *, timeout_s: float = 5.0) -> FlightResult:
        """Switch to Hold (PX4 AUTO.LOITER): stop and hover where the vehicle is."""
        op = self._begin("hold")
        ack = await self._command(
            MAV_CMD_DO_SET_MODE,
            (float(MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(MainMode.AUTO), float(AutoSubMode.LOITER)),
        )
        if not ack.accepted:
            return self._refused(op, ack)
        status, reason, reached = await self._fly_wait(op, lambda s: s.mode == "hold", timeout_s, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def hover(self, duration_s: float, *, timeout_s: float | None = None) -> FlightResult:
        """Hold for ``duration_s`` of the *vehicle's* clock (GLOBAL_POSITION_INT.time_boot_ms: simulated time in a
        simulator, so a faster-than-real-time sim hovers in less wall time)."""
        held = await self.hold()
        if not held.ok:
            return held.model_copy(update={"action": "hover"})
        op = self._begin("hover")
        start = self.telemetry.time_boot_s
        if start is None:
            return self._result(op, "failed", reason="no GLOBAL_POSITION_INT: the vehicle's clock is unknown")
        wait = timeout_s if timeout_s is not None else 2.0 * duration_s + 30.0

        def elapsed(s: TelemetryState) -> bool:
            return s.time_boot_s is not None and s.time_boot_s - start >= duration_s

        status, reason, _ = await self._fly_wait(op, elapsed, wait)
        return self._result(op, status, reason=reason, ack=held.ack)

    def _landed(self, s: TelemetryState) -> bool:
        return not s.armed or s.landed_state == "on_ground"

    def _done_before_resend(self, ack: Ack) -> bool:
        """A land or a return whose first copy was heard and done before the copy sent again (the ACK lost, the
        vehicle faster than the wall clock) is refused as 'not flying': on the ground, that refusal is not one."""
        with self._lock:
            return ack.resent and self._landed(self._state)

    async def land(self, *, timeout_s: float | None = None) -> FlightResult:
        """Land where the vehicle is and wait until it is on the ground (PX4 disarms on touchdown)."""
        op = self._begin("land")
        nan = math.nan
        ack = await self._command(MAV_CMD_NAV_LAND, (0.0, 0.0, 0.0, nan, nan, nan, nan))
        if not ack.accepted and not self._done_before_resend(ack):
            return self._refused(op, ack)
        with self._lock:
            alt = self._state.alt_m or 0.0
        wait = timeout_s if timeout_s is not None else 30.0 + abs(alt) / 0.5
        status, reason, reached = await self._fly_wait(op, self._landed, wait, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def rtl(self, *, timeout_s: float | None = None, home_acceptance_m: float = 5.0) -> FlightResult:
        """Return to launch and land there; ``reached`` is landed within ``home_acceptance_m`` of home."""
        op = self._begin("rtl")
        ack = await self._command(MAV_CMD_NAV_RETURN_TO_LAUNCH, ())
        if not ack.accepted and not self._done_before_resend(ack):
            return self._refused(op, ack)
        home = self.home
        with self._lock:
            s = self._state
            dist = (self._distance_to(s, home[0], home[1]) if home else None) or 0.0
            alt = s.alt_m or 0.0
        wait = timeout_s if timeout_s is not None else 60.0 + dist / 2.0 + 2.0 * alt
        status, reason, landed = await self._fly_wait(op, self._landed, wait, flying=False)
        reached = landed
        if landed and home is not None:
            with self._lock:
                off = self._distance_to(self._state, home[0], home[1])
            if off is not None and off > home_acceptance_m:
                reached, reason = False, f"landed {off:.1f} m from home"
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def deploy_payload(self, *, instance: int = 1) -> FlightResult:
        """Release the payload (DO_GRIPPER RELEASE). There is no telemetry of the payload: the ACK is the answer."""
        op = self._begin("deploy_payload")
        ack = await self._command(MAV_CMD_DO_GRIPPER, (float(instance), float(GRIPPER_ACTION_RELEASE)))
        if not ack.accepted:
            return self._refused(op, ack)
        return self._result(op, "ok", ack=ack.result)

    async def orbit(
        self,
        lat: float,
        lon: float,
        radius_m: float,
        *,
        turns: float = 1.0,
        alt_m: float | None = None,
        speed_mps: float | None = None,
        clockwise: bool = True,
        timeout_s: float | None = None,
    ) -> FlightResult:
        """Circle ``lat, lon`` at ``radius_m`` for ``turns``, then hold. Tries DO_ORBIT and counts the turns from
        the position; a vehicle that answers it UNSUPPORTED (the simulated one does) is flown around the circle
        as DO_REPOSITION waypoints instead, which ``reason`` says."""
        if not (radius_m > 0 and turns > 0 and math.isfinite(radius_m) and math.isfinite(turns)):
            op = self._begin("orbit")
            return self._result(op, "failed", reason="radius_m and turns must be positive")
        circumference = 2.0 * math.pi * radius_m
        if timeout_s is None:
            with self._lock:
                dist = self._distance_to(self._state, lat, lon) or 0.0
            timeout_s = 60.0 + (dist + turns * circumference) / 1.5
        deadline = time.monotonic() + timeout_s
        op = self._begin("orbit")
        direction = 1.0 if clockwise else -1.0
        ack = await self._command(
            MAV_CMD_DO_ORBIT,
            (direction * radius_m, math.nan if speed_mps is None else speed_mps, 0.0, turns),
            frame=MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            x=round(lat * 1e7),
            y=round(lon * 1e7),
            z=math.nan if alt_m is None else alt_m,
        )  # resent like every command when no ACK comes: a second identical orbit changes nothing
        if ack.result == MAV_RESULT_UNSUPPORTED:
            self._end(op)
            return await self._orbit_waypoints(lat, lon, radius_m, turns, alt_m, speed_mps, direction, deadline)
        if not ack.accepted:
            return self._refused(op, ack)
        # DO_ORBIT accepted: count the angle swept around the centre, then hold.
        swept = [0.0, math.nan]

        def turned(s: TelemetryState) -> bool:
            if s.lat_deg is None or s.lon_deg is None:
                return False
            north, east = local_offset(lat, lon, s.lat_deg, s.lon_deg)
            if math.hypot(north, east) < 0.5 * radius_m:
                return False
            angle = math.atan2(east, north)
            if not math.isnan(swept[1]):
                swept[0] += math.remainder(angle - swept[1], 2.0 * math.pi) * direction
            swept[1] = angle
            return swept[0] >= turns * 2.0 * math.pi

        status, reason, reached = await self._fly_wait(op, turned, max(0.0, deadline - time.monotonic()))
        if status != "ok":
            return self._result(op, status, reason=reason, reached=reached, ack=ack.result)
        self._end(op)
        held = await self.hold()
        return held.model_copy(update={"action": "orbit", "reached": held.ok, "reason": held.reason})

    async def _orbit_waypoints(
        self,
        lat: float,
        lon: float,
        radius_m: float,
        turns: float,
        alt_m: float | None,
        speed_mps: float | None,
        direction: float,
        deadline: float,
    ) -> FlightResult:
        started = time.monotonic()
        with self._lock:
            s = self._state
            known = s.lat_deg is not None and s.lon_deg is not None
            here = local_offset(lat, lon, s.lat_deg or 0.0, s.lon_deg or 0.0) if known else None
        if here is None:
            op = self._begin("orbit")
            return self._result(op, "failed", reason="no position from the vehicle")
        start_angle = math.atan2(here[1], here[0])
        per_turn = min(72, max(8, math.ceil(2.0 * math.pi * radius_m / 8.0)))
        count = max(1, math.ceil(turns * per_turn))
        step = direction * turns * 2.0 * math.pi / count
        note = f"the vehicle does not support DO_ORBIT: flown as {count + 1} waypoints on the circle"
        result: FlightResult | None = None
        for k in range(count + 1):
            angle = start_angle + k * step
            wlat, wlon = offset_position(lat, lon, radius_m * math.cos(angle), radius_m * math.sin(angle))
            left = deadline - time.monotonic()
            result = await self.goto(
                wlat,
                wlon,
                alt_m,
                speed_mps=speed_mps,
                timeout_s=max(0.0, left),
                acceptance_m=max(1.5, min(3.0, 0.15 * radius_m)),
                alt_tolerance_m=2.0,
                action="orbit",
            )
            if not result.ok:
                why = f"waypoint {k + 1}/{count + 1}: {result.reason}"
                return result.model_copy(update={"reason": f"{note}; {why}", "elapsed_s": time.monotonic() - started})
        assert result is not None
        return result.model_copy(update={"reason": note, "elapsed_s": time.monotonic() - started})

    async def wait_telemetry(self, timeout_s: float = 5.0) -> Telemetry | None:
        """The telemetry once a position has arrived (None after ``timeout_s``)."""
        found = await self._wait(lambda _m: True if self._state.lat_deg is not None else None, timeout_s)
        return self.telemetry if found else None
