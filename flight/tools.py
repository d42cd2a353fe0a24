"""The ``flight.*`` tools: the mission DSL's flight actions (and the agent's) as guarded tools over a VehicleClient.

Every action reaches the aircraft through the tools executor, so scopes, timeouts and the audit log apply to it.
The arguments are those of :mod:`agentic_core.contracts.flight_args`, the models the mission DSL's are derived
from (without the DSL's ``${...}`` templates): the parameters carry its value types and its cross-field rules
(one destination, one centre, one landing place) are checked by its models.

=========================  =======================================================  ==================
tool                       arguments                                                scope
=========================  =======================================================  ==================
``flight.takeoff``         ``altitude_m`` (arms first when disarmed)                ``flight:command``
``flight.fly_to``          ``lat``/``lon`` or ``north_m``/``east_m`` (from home) or  ``flight:command``
                           ``target_id``; ``alt_m``, ``speed_mps``
``flight.orbit``           ``center`` {lat, lon} or ``target_id``; ``radius_m``,    ``flight:command``
                           ``turns``, ``alt_m``
``flight.hover``           ``duration_s`` (of the vehicle's clock)                  ``flight:command``
``flight.land``            here, or ``lat``/``lon``, or ``target_id``; ``offset_m``  ``flight:command``
``flight.rtl``             none                                                     ``flight:command``
``flight.hold``            none (stop where you are: the mission's abort)           ``flight:command``
``flight.deploy_payload``  ``payload``                                              ``flight:payload``
``flight.upload_mission``  ``items`` (:class:`~flight.vehicle.MissionItem`),        ``flight:command``
                           ``mission_type`` (``mission``, ``fence``, ``rally``)
``flight.start_mission``   ``from_item``, ``wait`` (until the mission is complete)  ``flight:command``
``flight.status``          none: the latest telemetry                               ``flight:read``
``flight.set_fence``       ``max_alt_m``; ``polygon`` or ``center``+``radius_m``;     ``flight:command``
                           ``floor_m`` (the vehicle enforces them itself)
``flight.inject_failure``  ``fault`` (a scheduled fault's kind), ``value``          ``flight:fault``
                           (sets ``SYS_FAILURE_EN`` first; for rehearsals only)
=========================  =======================================================  ==================

``flight:fault`` is a scope the agent never holds: only a run's fault schedule calls ``flight.inject_failure``.

A ``target_id`` names an object of the world model: the tools are given a resolver (``targets``: id → latitude and
longitude, or None for an id it does not know); without one, such a call is an error saying so. Landing beside a
target stops ``offset_m`` short of it on the line from where the aircraft is, so it never flies over the person.
Flight tools act on the aircraft: they are not idempotent, never retried and never cached, and their timeouts are
minutes. A refused, failed or timed-out action raises :class:`~tools.ToolError` with the
vehicle's reason, so its ToolResult is ``error`` with that reason; an action that completed returns the
:class:`~flight.vehicle.FlightResult` (an upload, the :class:`~flight.vehicle.MissionResult`). The mission tools
have no mission DSL action: they hand the vehicle a whole plan (a survey pattern, a fence) to fly on its own.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Awaitable, Callable
from typing import Annotated, Any, Literal

from pydantic import Field, ValidationError

from agentic_core.contracts.faults import FaultKind
from agentic_core.contracts.flight_args import (
    FlyToArgs,
    LandArgs,
    Latitude,
    LatLon,
    Longitude,
    NonNegative,
    Number,
    OrbitArgs,
    Positive,
)
from agentic_core.contracts.geodesy import local_offset, offset_position
from tools import ToolError, ToolRegistry, ToolSpec
from tools.function import spec_from_function

from .client.safety import failure_command
from .vehicle import FlightResult, MissionItem, MissionResult, Telemetry, VehicleClient

ClientFactory = Callable[[], Awaitable[VehicleClient]]
"""Connects a client when a flight tool first needs one (e.g. ``lambda: VehicleClient.connect("127.0.0.1:14540")``)."""

SCOPE_COMMAND = "flight:command"
SCOPE_PAYLOAD = "flight:payload"
SCOPE_READ = "flight:read"
SCOPE_FAULT = "flight:fault"

TIMEOUTS_S: dict[str, float] = {
    "flight.takeoff": 180.0,
    "flight.fly_to": 900.0,
    "flight.orbit": 1800.0,
    "flight.hover": 3600.0,
    "flight.land": 600.0,
    "flight.rtl": 1800.0,
    "flight.hold": 30.0,
    "flight.deploy_payload": 30.0,
    "flight.upload_mission": 120.0,
    "flight.start_mission": 3600.0,
    "flight.status": 10.0,
    "flight.set_fence": 60.0,
    "flight.inject_failure": 30.0,
}
"""Each tool's own timeout (the executor's bound on one call; a mission step's ``timeout_s`` may shorten it)."""

NEEDS_WORLD_MODEL = "target_id needs a world model, and this vehicle's tools were given none (run with perception)"

TargetResolver = Callable[[str], "tuple[float, float] | None"]
"""Where a world-model object is: its id → (latitude, longitude), or None when there is no such object."""

Lat = Annotated[Latitude, Field(description="latitude, degrees (WGS-84)")]
Lon = Annotated[Longitude, Field(description="longitude, degrees (WGS-84)")]


def _check(build: Callable[[], object]) -> None:
    """Build an argument model to apply its cross-field rules; a broken rule is a ToolError saying which."""
    try:
        build()
    except ValidationError as exc:
        raise ToolError("; ".join(e["msg"].removeprefix("Value error, ") for e in exc.errors())) from None


class _ClientSource:
    """The client the tools use: a given one, or one the factory connects on first use (and again if closed)."""

    def __init__(self, source: VehicleClient | ClientFactory) -> None:
        self._client = source if isinstance(source, VehicleClient) else None
        self._factory = None if isinstance(source, VehicleClient) else source
        self._lock = threading.Lock()

    async def get(self) -> VehicleClient:
        client = self._client
        if client is not None and not client.closed:
            return client
        if self._factory is None:
            raise ToolError("the vehicle link is closed")
        try:
            client = await self._factory()
        except Exception as exc:
            raise ToolError(f"cannot connect to the vehicle: {exc}") from None
        with self._lock:
            current = self._client
            if current is not None and not current.closed:  # another call connected meanwhile
                client.close()
                return current
            self._client = client
        return client


def _done(result: FlightResult) -> FlightResult:
    """The result of an action that completed; anything else is a ToolError with the vehicle's reason."""
    if result.status != "ok":
        raise ToolError(f"{result.action} {result.status}: {result.reason or 'no reason given'}")
    return result


def flight_tools(source: VehicleClient | ClientFactory, targets: TargetResolver | None = None) -> list[ToolSpec]:
    """The ``flight.*`` tool specs bound to a client (or a factory that connects one on first use), resolving
    ``target_id`` with ``targets``."""
    clients = _ClientSource(source)

    def where(target_id: str) -> tuple[float, float]:
        if targets is None:
            raise ToolError(NEEDS_WORLD_MODEL)
        position = targets(target_id)
        if position is None:
            raise ToolError(f"there is no object {target_id!r} in the world model")
        return position

    async def takeoff(altitude_m: Positive = 10.0) -> FlightResult:
        """Take off and climb to a height above home, arming first if needed; returns when there.

        Args:
            altitude_m: climb to this height above home, in metres
        """
        client = await clients.get()
        if not client.telemetry.armed:
            _done(await client.arm())
        return _done(await client.takeoff(altitude_m))

    async def fly_to(
        lat: Lat | None = None,
        lon: Lon | None = None,
        north_m: Number | None = None,
        east_m: Number | None = None,
        target_id: str | None = None,
        alt_m: NonNegative | None = None,
        speed_mps: Positive | None = None,
    ) -> FlightResult:
        """Fly to a position and hold there; returns when arrived. Give exactly one destination.

        Args:
            lat: latitude of the destination (with lon)
            lon: longitude of the destination (with lat)
            north_m: metres north of home (with east_m)
            east_m: metres east of home (with north_m)
            target_id: an object id of the world model, e.g. P-12
            alt_m: height above home; default: keep the current one
            speed_mps: horizontal speed; default: the vehicle's cruise speed
        """
        _check(lambda: FlyToArgs(lat=lat, lon=lon, north_m=north_m, east_m=east_m, target_id=target_id))
        if target_id is not None:
            lat, lon = where(target_id)
        client = await clients.get()
        if lat is not None and lon is not None:
            return _done(await client.goto(lat, lon, alt_m, speed_mps=speed_mps, action="fly_to"))
        if north_m is not None and east_m is not None:
            return _done(await client.goto_local(north_m, east_m, alt_m, speed_mps=speed_mps, action="fly_to"))
        raise AssertionError("FlyToArgs lets no other destination through")

    async def orbit(
        radius_m: Positive,
        center: LatLon | None = None,
        target_id: str | None = None,
        turns: Positive = 1.0,
        alt_m: NonNegative | None = None,
    ) -> FlightResult:
        """Circle a point (clockwise) for a number of turns, then hold; returns when done.

        Args:
            radius_m: the circle's radius in metres
            center: the point to circle
            target_id: an object id of the world model to circle instead of center
            turns: how many times round
            alt_m: height above home; default: keep the current one
        """
        _check(lambda: OrbitArgs(center=center, target_id=target_id, radius_m=radius_m))
        if center is None and target_id is not None:
            lat, lon = where(target_id)
            center = LatLon(lat=lat, lon=lon)
        assert center is not None
        client = await clients.get()
        return _done(await client.orbit(center.lat, center.lon, radius_m, turns=turns, alt_m=alt_m))

    async def hover(duration_s: Positive) -> FlightResult:
        """Hold position for a while (measured on the vehicle's clock).

        Args:
            duration_s: how long to hover, in seconds
        """
        client = await clients.get()
        return _done(await client.hover(duration_s))

    async def land(
        lat: Lat | None = None,
        lon: Lon | None = None,
        target_id: str | None = None,
        offset_m: NonNegative = 0.0,
    ) -> FlightResult:
        """Land here, or fly to lat/lon first; returns when on the ground.

        Args:
            lat: latitude to land at (with lon); default: here
            lon: longitude to land at (with lat)
            target_id: an object id of the world model to land beside
            offset_m: keep this distance from the target when landing (only with target_id)
        """
        _check(lambda: LandArgs(lat=lat, lon=lon, target_id=target_id))
        client = await clients.get()
        if target_id is not None:
            lat, lon = beside(client.telemetry, *where(target_id), offset_m)
        if lat is not None and lon is not None:
            _done(await client.goto(lat, lon, None, action="land"))
        return _done(await client.land())

    async def rtl() -> FlightResult:
        """Return to the launch point and land there; returns when on the ground."""
        client = await clients.get()
        return _done(await client.rtl())

    async def hold() -> FlightResult:
        """Stop and hold position where the vehicle is (ends any flight action under way)."""
        client = await clients.get()
        return _done(await client.hold())

    async def deploy_payload(payload: str = "rescue_kit") -> FlightResult:
        """Release the payload.

        Args:
            payload: what is carried, for the record (the vehicle has one release)
        """
        client = await clients.get()
        result = _done(await client.deploy_payload())
        return result.model_copy(update={"reason": f"released {payload}"})

    async def upload_mission(
        items: list[MissionItem], mission_type: Literal["mission", "fence", "rally"] = "mission"
    ) -> MissionResult:
        """Hand the vehicle a whole plan, replacing the one it holds of that type; returns once it has it.

        Args:
            items: the plan in order; each a MAVLink command (22 take-off, 16 waypoint, 19 loiter for a time,
                21 land, 20 return, 178 change speed, 211 gripper) with lat/lon/alt (alt above home)
            mission_type: mission (a flight plan), fence (areas to stay in or out of) or rally (safe points)
        """
        client = await clients.get()
        result = await client.upload_mission(items, mission_type=mission_type)
        if not result.ok:
            raise ToolError(f"upload_mission {result.status}: {result.reason or result.result or 'no reason given'}")
        return result

    async def start_mission(from_item: Annotated[int, Field(ge=0)] | None = None, wait: bool = True) -> FlightResult:
        """Fly the uploaded mission (arming and taking off if on the ground); with wait, return when it is done.

        Args:
            from_item: start from this item (default: the current one; a finished mission starts over)
            wait: wait until the vehicle reports the mission complete
        """
        client = await clients.get()
        started = _done(await client.start_mission(from_item=from_item))
        if not wait:
            return started
        return _done(await client.wait_mission(timeout_s=TIMEOUTS_S["flight.start_mission"]))

    async def status() -> Telemetry:
        """The vehicle's latest telemetry: position, altitude above home, battery, armed, mode, landed state."""
        client = await clients.get()
        return client.telemetry

    async def set_fence(
        max_alt_m: Positive,
        polygon: list[LatLon] | None = None,
        center: LatLon | None = None,
        radius_m: Positive | None = None,
        floor_m: NonNegative | None = None,
    ) -> dict[str, Any]:
        """Give the vehicle a mission's limits to enforce itself: an inclusion fence (a polygon, or a circle of
        radius_m around center; neither clears it), the ceiling, the floor, the return altitude capped under the
        ceiling; all read back.

        Args:
            max_alt_m: the ceiling, metres above home
            polygon: the fence's corners, in order
            center: the centre of a circular fence (with radius_m)
            radius_m: the radius of a circular fence, metres
            floor_m: the lowest a target may be above home, metres (take-off and landing aside)
        """
        if polygon is not None and center is not None:
            raise ToolError("give a polygon or a circle (center and radius_m), not both")
        if (center is None) != (radius_m is None):
            raise ToolError("a circular fence needs both center and radius_m")
        client = await clients.get()
        result = await client.upload_fence(
            polygon=[(p.lat, p.lon) for p in polygon] if polygon is not None else None,
            circle=(center.lat, center.lon, radius_m) if center is not None and radius_m is not None else None,
            max_alt_m=max_alt_m,
            floor_m=floor_m,
        )
        if result.status != "ok":
            raise ToolError(f"the vehicle did not take the fence ({result.status}): {result.reason}")
        return {"items": result.items, "params": result.params}

    async def inject_failure(fault: FaultKind, value: Number | None = None) -> FlightResult:
        """Make a failure happen on the vehicle, to rehearse a failsafe: MAV_CMD_INJECT_FAILURE, after setting
        SYS_FAILURE_EN to 1 (a vehicle that refuses either says why).

        Args:
            fault: battery (with value: the level it reads, percent), battery_low, battery_critical, gps_loss,
                link_loss, motor (with value: its number)
            value: the battery's level in percent, or the motor's number
        """
        try:
            unit, failure_type, instance, param4 = failure_command(fault, value)
        except ValueError as exc:
            raise ToolError(str(exc)) from None
        client = await clients.get()
        if await client.set_param("SYS_FAILURE_EN", 1) != 1:
            raise ToolError("the vehicle did not enable failure injection (SYS_FAILURE_EN)")
        return _done(await client.inject_failure(unit, failure_type, instance, param4))

    def spec(fn: Callable[..., Any], name: str, scope: str) -> ToolSpec:
        return spec_from_function(fn, name=name, scopes=[scope], timeout_s=TIMEOUTS_S[name], idempotent=False)

    return [
        spec(takeoff, "flight.takeoff", SCOPE_COMMAND),
        spec(fly_to, "flight.fly_to", SCOPE_COMMAND),
        spec(orbit, "flight.orbit", SCOPE_COMMAND),
        spec(hover, "flight.hover", SCOPE_COMMAND),
        spec(land, "flight.land", SCOPE_COMMAND),
        spec(rtl, "flight.rtl", SCOPE_COMMAND),
        spec(hold, "flight.hold", SCOPE_COMMAND),
        spec_from_function(
            deploy_payload,
            name="flight.deploy_payload",
            scopes=[SCOPE_PAYLOAD],
            timeout_s=TIMEOUTS_S["flight.deploy_payload"],
            side_effects=True,  # a release must never repeat on a resumed run: replayed by idempotency key
        ),
        spec(upload_mission, "flight.upload_mission", SCOPE_COMMAND),
        spec(start_mission, "flight.start_mission", SCOPE_COMMAND),
        spec(status, "flight.status", SCOPE_READ),
        spec(set_fence, "flight.set_fence", SCOPE_COMMAND),
        spec(inject_failure, "flight.inject_failure", SCOPE_FAULT),
    ]


def beside(telemetry: Telemetry, lat: float, lon: float, offset_m: float) -> tuple[float, float]:
    """The point ``offset_m`` short of ``lat, lon`` on the line from the aircraft (straight south of it when the
    aircraft's position is unknown or right above it)."""
    if offset_m <= 0:
        return lat, lon
    north, east = -1.0, 0.0
    if telemetry.lat_deg is not None and telemetry.lon_deg is not None:
        north, east = local_offset(lat, lon, telemetry.lat_deg, telemetry.lon_deg)
    distance = math.hypot(north, east)
    if distance < 1e-3:
        north, east, distance = -1.0, 0.0, 1.0
    return offset_position(lat, lon, north / distance * offset_m, east / distance * offset_m)


def register_flight_tools(
    registry: ToolRegistry,
    source: VehicleClient | ClientFactory,
    *,
    targets: TargetResolver | None = None,
    replace: bool = False,
) -> list[str]:
    """Register the ``flight.*`` tools bound to ``source`` (a connected client, or a factory connecting one on
    first use), resolving ``target_id`` with ``targets``; returns their names."""
    return [registry.register(s, replace=replace).name for s in flight_tools(source, targets)]


__all__ = [
    "NEEDS_WORLD_MODEL",
    "SCOPE_COMMAND",
    "SCOPE_PAYLOAD",
    "SCOPE_READ",
    "TIMEOUTS_S",
    "ClientFactory",
    "TargetResolver",
    "beside",
    "flight_tools",
    "register_flight_tools",
]
