"""Safety set-up from the client: the geofence and altitude limits uploaded and verified in one call, and
failures injected for tests.

Why: the vehicle enforces its fence whatever the agent later asks (:mod:`flight.mavlink.failsafe`,
:mod:`flight.mavlink.fence_predict`), but only the fence it was given. Before take-off the run hands it the
mission's geofence as MAVLink fence items and sets the altitude limits; :meth:`SafetyClient.upload_fence` does both
and then reads everything back, so "uploaded" means "the vehicle holds it", not "we sent it".

Facts relied on (MAVLink ``common.xml`` through pymavlink; PX4 parameter reference; our vehicle's parameters in
:mod:`flight.mavlink.params`):

* Fence items (plan type ``fence``): NAV_FENCE_POLYGON_VERTEX_INCLUSION 5001 (param1 the vertex count, one item per
  vertex) and NAV_FENCE_CIRCLE_INCLUSION 5003 (param1 the radius), latitude/longitude in x/y.
* ``GF_MAX_VER_DIST`` is the ceiling above home (PX4's name); ``RTL_RETURN_ALT`` is capped
  :data:`RETURN_MARGIN_M` under it, as the vehicle caps its own return; ``GF_MIN_ALT`` is the floor (ours: PX4 has
  none, a vehicle without it ignores the write and the read-back says so).
* MAV_CMD_INJECT_FAILURE 420 (param1 FAILURE_UNIT, param2 FAILURE_TYPE, param3 instance), honoured only with
  ``SYS_FAILURE_EN`` 1 (PX4 and our vehicle).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Literal, Protocol

from pydantic import BaseModel, ConfigDict, Field
from pymavlink.dialects.v20.common import (  # MAVLink's own constants
    FAILURE_TYPE_OFF,
    FAILURE_TYPE_SLOW,
    FAILURE_TYPE_WRONG,
    FAILURE_UNIT_SENSOR_GPS,
    FAILURE_UNIT_SYSTEM_BATTERY,
    FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL,
    FAILURE_UNIT_SYSTEM_MOTOR,
    MAV_CMD_INJECT_FAILURE,
)

from agentic_core.contracts.faults import value_problem
from flight.client.mission import MissionClient
from flight.client.mission_items import MissionItem
from flight.client.operations import Operation
from flight.client.results import FlightResult
from flight.client.telemetry import Telemetry

RETURN_MARGIN_M = 1.0
"""``RTL_RETURN_ALT`` is set at most this far under the ceiling."""
COORD_TOLERANCE_DEG = 2e-7
"""Read-back coordinates match within this (the wire carries degrees × 1e7 as integers)."""
PARAM_TOLERANCE = 1e-3

FenceStatus = Literal["ok", "denied", "timeout", "failed"]


class FenceResult(BaseModel):
    """What :meth:`SafetyClient.upload_fence` did, and what the vehicle holds afterwards."""

    model_config = ConfigDict(frozen=True)

    status: FenceStatus = Field(
        description="ok (uploaded and read back); denied (the vehicle refused the fence or a parameter); timeout "
        "(it stopped answering); failed (bad input, or the read-back differs)"
    )
    reason: str | None = None
    items: int = Field(ge=0, description="fence items the vehicle holds (read back)")
    params: dict[str, float] = Field(default_factory=dict, description="the limits as read back from the vehicle")
    elapsed_s: float = Field(ge=0)
    state: Telemetry

    @property
    def ok(self) -> bool:
        return self.status == "ok"


def fence_items(
    polygon: Sequence[tuple[float, float]] | None, circle: tuple[float, float, float] | None
) -> list[MissionItem]:
    """The fence items for one inclusion ``polygon`` of (lat, lon) vertices or one ``circle`` (lat, lon, radius in
    metres); raises ValueError naming what is wrong."""
    if polygon is not None and circle is not None:
        raise ValueError("give a polygon or a circle, not both")
    if polygon is not None:
        vertices = [(float(lat), float(lon)) for lat, lon in polygon]
        if len(vertices) < 3:
            raise ValueError(f"a fence polygon needs at least 3 vertices, not {len(vertices)}")
        for i, (lat, lon) in enumerate(vertices):
            if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
                raise ValueError(f"polygon vertex {i}: ({lat}, {lon}) is not a latitude/longitude")
        return MissionItem.fence_polygon(vertices)
    if circle is not None:
        lat, lon, radius = (float(x) for x in circle)
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise ValueError(f"circle centre ({lat}, {lon}) is not a latitude/longitude")
        if not (math.isfinite(radius) and radius > 0):
            raise ValueError(f"circle radius must be a positive number of metres, not {radius}")
        return [MissionItem.fence_circle(lat, lon, radius)]
    return []


FAILURES: dict[str, tuple[int, int]] = {
    "battery": (FAILURE_UNIT_SYSTEM_BATTERY, FAILURE_TYPE_WRONG),
    "battery_low": (FAILURE_UNIT_SYSTEM_BATTERY, FAILURE_TYPE_SLOW),
    "battery_critical": (FAILURE_UNIT_SYSTEM_BATTERY, FAILURE_TYPE_OFF),
    "gps_loss": (FAILURE_UNIT_SENSOR_GPS, FAILURE_TYPE_OFF),
    "link_loss": (FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL, FAILURE_TYPE_OFF),
    "motor": (FAILURE_UNIT_SYSTEM_MOTOR, FAILURE_TYPE_OFF),
}
"""Each scheduled fault (:mod:`agentic_core.contracts.faults`) as MAV_CMD_INJECT_FAILURE's unit and type; a
battery level is our FAILURE_TYPE_WRONG with the percentage in param4 (:mod:`flight.mavlink.failures`)."""


def failure_command(fault: str, value: float | None = None) -> tuple[int, int, int, float | None]:
    """MAV_CMD_INJECT_FAILURE's (unit, type, instance, param4) for a fault; ValueError naming what is wrong.

    >>> failure_command("battery", 18.0)[1:]
    (4, 0, 18.0)
    """
    if fault not in FAILURES:
        raise ValueError(f"no fault {fault!r}; the faults are {', '.join(FAILURES)}")
    problem = value_problem(fault, value)
    if problem:
        raise ValueError(problem)
    unit, failure_type = FAILURES[fault]
    if fault == "motor" and value is not None:
        return unit, failure_type, int(value), None
    return unit, failure_type, 0, value if fault == "battery" else None


class SafetyClient(MissionClient):
    """The fence and altitude limits, and failure injection."""

    async def upload_fence(
        self,
        *,
        polygon: Sequence[tuple[float, float]] | None = None,
        circle: tuple[float, float, float] | None = None,
        max_alt_m: float,
        floor_m: float | None = None,
    ) -> FenceResult:
        """Upload an inclusion ``polygon`` ((lat, lon) vertices) or ``circle`` ((lat, lon, radius m)) as the
        vehicle's fence plan (neither: clear it), set the ceiling ``GF_MAX_VER_DIST`` to ``max_alt_m``, the floor
        ``GF_MIN_ALT`` to ``floor_m`` (None: unchanged) and cap ``RTL_RETURN_ALT`` under the ceiling; then read it
        all back. Armed, the vehicle takes these only from a signed link: what it already holds is not sent again
        (a resumed run's own fence). Never raises for bad input or a refusal.

        >>> import asyncio
        >>> from flight.mavlink import MavlinkVehicle
        >>> from flight.sim import Simulator
        >>> from flight.vehicle import VehicleClient
        >>> async def demo():
        ...     with MavlinkVehicle(Simulator(), gcs=None, api=None) as vehicle:
        ...         vehicle.start(speed=None)
        ...         async with await VehicleClient.connect(vehicle.address) as client:
        ...             home = vehicle.sim.environment.home
        ...             result = await client.upload_fence(
        ...                 circle=(home.lat_deg, home.lon_deg, 200.0), max_alt_m=25.0, floor_m=2.0
        ...             )
        ...             return result.status, result.items, result.params["RTL_RETURN_ALT"]
        >>> asyncio.run(demo())
        ('ok', 1, 24.0)
        """
        started = time.monotonic()

        def done(
            status: FenceStatus, reason: str | None = None, items: int = 0, params: dict[str, float] | None = None
        ) -> FenceResult:
            return FenceResult(
                status=status,
                reason=reason,
                items=items,
                params=params or {},
                elapsed_s=time.monotonic() - started,
                state=self.telemetry,
            )

        try:
            items = fence_items(polygon, circle)
            if not (math.isfinite(max_alt_m) and max_alt_m > RETURN_MARGIN_M):
                raise ValueError(f"max_alt_m must be above {RETURN_MARGIN_M:g} m, not {max_alt_m}")
            if floor_m is not None and not (math.isfinite(floor_m) and 0 <= floor_m < max_alt_m - RETURN_MARGIN_M):
                raise ValueError(f"floor_m must be at least 0 and under the ceiling less 1 m, not {floor_m}")
        except (TypeError, ValueError) as exc:
            return done("failed", f"bad fence: {exc}")
        # Armed, a vehicle takes a new fence or safety limit only from a signed link; one it already holds (a
        # resumed run's own) is kept rather than sent again, so an unsigned link may go on with it.
        armed = self.telemetry.armed
        if not (armed and await self._holds_fence(items)):
            upload = (
                await self.upload_mission(items, mission_type="fence")
                if items
                else await self.clear_mission(mission_type="fence")
            )
            if not upload.ok:
                return done(upload.status, f"fence upload: {upload.reason}")
        current_rtl = await self.get_param("RTL_RETURN_ALT")
        if current_rtl is None:
            return done("timeout", "no answer to reading RTL_RETURN_ALT")
        wanted = {"GF_MAX_VER_DIST": max_alt_m, "RTL_RETURN_ALT": min(current_rtl, max_alt_m - RETURN_MARGIN_M)}
        if floor_m is not None:
            wanted["GF_MIN_ALT"] = floor_m
        for name, value in wanted.items():
            if armed and _near(await self.get_param(name), value):
                continue
            if await self.set_param(name, value) is None:
                return done("timeout", f"no answer to setting {name}")
        return await self._verify_fence(items, wanted, done)

    async def _holds_fence(self, items: list[MissionItem]) -> bool:
        """Whether the vehicle's fence plan is ``items`` already."""
        held = await self.download_mission(mission_type="fence")
        return held.ok and _same_items(items, held.items)

    async def _verify_fence(self, items: list[MissionItem], wanted: dict[str, float], done: _Done) -> FenceResult:
        """Read the fence plan and the limits back and compare them with what was sent."""
        held = await self.download_mission(mission_type="fence")
        if not held.ok:
            return done(held.status, f"fence read-back: {held.reason}")
        got: dict[str, float] = {}
        for name in wanted:
            value = await self.get_param(name)
            if value is None:
                return done("timeout", f"no answer to reading {name} back", held.count)
            got[name] = value
        mismatch = [
            f"{name} is {got[name]:g}, not {value:g}" for name, value in wanted.items() if not _near(got[name], value)
        ]
        if mismatch:
            return done("denied", "the vehicle kept other limits: " + "; ".join(mismatch), held.count, got)
        if not _same_items(items, held.items):
            return done("failed", "the fence read back differs from the one sent", held.count, got)
        return done("ok", None, held.count, got)

    async def inject_failure(
        self, unit: int, failure_type: int, instance: int = 0, value: float | None = None
    ) -> FlightResult:
        """MAV_CMD_INJECT_FAILURE (FAILURE_UNIT, FAILURE_TYPE, instance; 0 all; ``value`` param4, our battery level
        for FAILURE_TYPE_WRONG). ``ok`` when accepted; ``denied`` (with the vehicle's reason) when
        ``SYS_FAILURE_EN`` is 0 or the values are nonsense; ``unsupported`` for a failure the vehicle cannot
        simulate. Does not interrupt the motion command under way."""
        op = Operation("inject_failure", time.monotonic(), self.telemetry.mode, self.text_mark)
        params = (float(unit), float(failure_type), float(instance)) + (() if value is None else (float(value),))
        ack = await self._command(MAV_CMD_INJECT_FAILURE, params)
        if not ack.accepted:
            return self._refused(op, ack)
        return self._result(op, "ok", ack=ack.result)


class _Done(Protocol):
    """The shape of ``upload_fence``'s result builder (for typing :meth:`SafetyClient._verify_fence`)."""

    def __call__(
        self, status: FenceStatus, reason: str | None = None, items: int = 0, params: dict[str, float] | None = None
    ) -> FenceResult: ...


def _near(got: float | None, value: float) -> bool:
    return got is not None and abs(got - value) <= PARAM_TOLERANCE * max(1.0, abs(value))


def _same_items(sent: list[MissionItem], held: list[MissionItem]) -> bool:
    if len(sent) != len(held):
        return False
    for a, b in zip(sent, held, strict=True):
        if a.command != b.command or abs(a.param1 - b.param1) > PARAM_TOLERANCE * max(1.0, abs(a.param1)):
            return False
        if abs((a.lat or 0.0) - (b.lat or 0.0)) > COORD_TOLERANCE_DEG:
            return False
        if abs((a.lon or 0.0) - (b.lon or 0.0)) > COORD_TOLERANCE_DEG:
            return False
    return True
