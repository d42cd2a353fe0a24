"""The one gate every leg a UAV of a swarm flies passes: its ``flight.*`` tools, wrapped so that a movement is
reserved in the swarm's :class:`~agentic_core.swarm.legs.LegBook` before the aircraft makes it, and flown as
reserved — it holds where it is until its start (a delay), goes to the layer granted over where it is, crosses in
that layer at the planned speed, and comes down only where the leg lands (a delivery, the way home). Arriving
early, it waits for the plan. Between legs, and while it hovers, it holds where it is, reserved as well.

A UAV the swarm has lost (its vehicle dead) flies no more: a command under way is given up at once, and any other
is refused. A newer command supersedes one still under way (a hold, the watch going over an object), as the vehicle
client's do: the older one raises the client's "superseded" error, and leaves the airspace to the newer one.
A refused leg is asked again every ``retry_s`` of the swarm's clock (others' legs end, their holds move on) for
``patience_s`` at most, then fails as a tool error the agent sees. ``flight.rtl`` flies home in its layer and lands
there (the autopilot's own return would climb to its return altitude through the other layers); its reservations
are then released. ``flight.orbit`` and ``flight.start_mission`` fly paths of their own the airspace cannot reserve:
in a swarm they are refused.

>>> import asyncio
>>> from flight.tools import register_flight_tools
>>> from agentic_core.swarm.deconflict import Airspace
>>> registry = ToolRegistry()
>>> _ = register_flight_tools(registry, lambda: None)
>>> book = LegBook(Airspace(), clock=lambda: 0.0, record=lambda event, **fields: None)
>>> pad = Point(north=0, east=0)
>>> gate_legs(registry, book, "uav-1", here=lambda: pad, origin=(21.4, 39.9), pad=pad)
>>> orbit = registry.get("flight.orbit").handler
>>> asyncio.run(orbit({"radius_m": 20}, ToolContext("1", "flight.orbit", None, 1, None)))  # doctest: +ELLIPSIS
Traceback (most recent call last):
tools.errors.ToolError: flight.orbit flies a path the swarm's airspace cannot reserve: fly it as fly_to legs
"""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from agentic_core.contracts.geodesy import local_offset, offset_position
from agentic_core.contracts.swarm import Point
from agentic_core.swarm.deconflict import NoSafeLeg
from agentic_core.swarm.legs import Grant, LegBook
from tools import ToolContext, ToolError, ToolRegistry, UnknownToolError

AT_M = 1.0
"""Closer than this to a place (and its layer) is being there: a leg there is a hold."""

UNRESERVABLE = ("flight.orbit", "flight.start_mission")

LOST_POLL_S = 0.1
"""How often (wall) a tool under way looks whether the swarm has its UAV lost."""

Targets = Callable[[str], "tuple[float, float] | None"]


class _Gate:
    def __init__(
        self,
        registry: ToolRegistry,
        book: LegBook,
        uav: str,
        *,
        here: Callable[[], Point],
        origin: tuple[float, float],
        pad: Point,
        targets: Targets,
        poll_s: float,
        retry_s: float,
        patience_s: float,
    ) -> None:
        self.registry, self.book, self.uav = registry, book, uav
        self.here, self.origin, self.pad, self.targets = here, origin, pad, targets
        self.poll_s, self.retry_s, self.patience_s = poll_s, retry_s, patience_s
        self.original: dict[str, Any] = {}
        self.latest = (0, "")
        """The newest movement command (number, tool): an older one still waiting gives way, as the client's do."""

    # ---- geometry ----

    def point(self, lat: float, lon: float, alt: float = 0.0) -> Point:
        north, east = local_offset(*self.origin, lat, lon)
        return Point(north=north, east=east, alt=alt)

    def latlon(self, p: Point) -> dict[str, float]:
        lat, lon = offset_position(*self.origin, p.north, p.east)
        return {"lat": lat, "lon": lon}

    def destination(self, args: dict[str, Any]) -> Point | None:
        """The leg's goal in the swarm's frame (None: a target the world model does not know, or no goal)."""
        if args.get("lat") is not None and args.get("lon") is not None:
            return self.point(float(args["lat"]), float(args["lon"]))
        if args.get("north_m") is not None and args.get("east_m") is not None:  # from the vehicle's own home
            return Point(north=self.pad.north + float(args["north_m"]), east=self.pad.east + float(args["east_m"]))
        if args.get("target_id") is not None:
            found = self.targets(str(args["target_id"]))
            return self.point(*found) if found is not None else None
        return None

    # ---- calling the real tools ----

    def start(self, tool: str) -> int:
        """A new movement command: any older one gives way to it. Its number."""
        self.latest = (self.latest[0] + 1, tool)
        return self.latest[0]

    def current(self, mine: int, tool: str) -> None:
        """Raise the client's error if a newer command superseded ``tool`` (command ``mine``)."""
        if self.latest[0] != mine:
            raise ToolError(f"{tool} failed: superseded by {self.latest[1]}")

    async def call(self, name: str, args: dict[str, Any], context: ToolContext, mine: int | None = None) -> Any:
        """The real tool; given up as soon as the swarm has this UAV lost (its vehicle is gone: waiting on it for
        the client's timeout would only hold the swarm's run open)."""
        if mine is not None:
            self.current(mine, context.tool)
        result = self.original[name](args, context)
        if not inspect.isawaitable(result):
            return result
        task = asyncio.ensure_future(result)
        while not task.done():
            if self.uav in self.book.lost:
                task.cancel()
                raise ToolError(f"{context.tool} given up: {self.uav} is lost to the swarm (its vehicle is gone)")
            await asyncio.wait({task}, timeout=LOST_POLL_S)
        return task.result()

    async def until(self, t: float, mine: int | None = None, tool: str = "") -> None:
        while self.book.clock() < t:
            if mine is not None:
                self.current(mine, tool)
            await asyncio.sleep(self.poll_s)

    async def reserve(
        self, mine: int, tool: str, goal: Point, *, land: bool = False, asked_m: float | None = None
    ) -> Grant:
        """The leg from here to ``goal``, asked again while refused (a hold where it is meanwhile)."""
        deadline = self.book.clock() + self.patience_s
        while True:
            if self.uav in self.book.lost:
                raise ToolError(f"{self.uav} is lost to the swarm: it may not fly")
            try:
                return self.book.request(self.uav, self.here(), goal, tool=tool, land=land, asked_m=asked_m)
            except NoSafeLeg as refused:
                self.book.hold(self.uav, self.here())
                if self.book.clock() >= deadline:
                    why = f"the swarm's airspace refused the leg for {self.patience_s:g} s: {refused}"
                    raise ToolError(why) from None
                await self.until(self.book.clock() + self.retry_s, mine, tool)

    async def to_layer(self, mine: int, grant: Grant, context: ToolContext) -> None:
        """Wait for the leg's start, then climb (or descend) to its layer over where the aircraft is."""
        await self.until(grant.go_s, mine, context.tool)
        now = self.here()
        if now.alt > AT_M and abs(now.alt - grant.layer_m) > AT_M:
            await self.call("flight.fly_to", {**self.latlon(now), "alt_m": grant.layer_m}, context, mine)
        up = self._index_at(grant, lambda p: abs(p.alt - grant.layer_m) < 1e-6)
        await self.until(grant.reached_s(up), mine, context.tool)

    async def across(self, mine: int, grant: Grant, goal: Point, context: ToolContext) -> Any:
        """Cross to over ``goal`` in the leg's layer at the planned speed; arriving early, wait for the plan."""
        speed = self.book.airspace.speed_mps
        args = {**self.latlon(goal), "alt_m": grant.layer_m, "speed_mps": speed}
        result = await self.call("flight.fly_to", args, context, mine)
        over = self._index_at(grant, lambda p: p.horizontal_to(goal) < 1e-6 and abs(p.alt - grant.layer_m) < 1e-6)
        await self.until(grant.reached_s(over), mine, context.tool)
        return result

    @staticmethod
    def _index_at(grant: Grant, where: Callable[[Point], bool]) -> int:
        points = grant.trajectory.waypoints
        return next((i for i, (_, p) in enumerate(points) if where(p)), len(points) - 1)

    def settle(self, mine: int) -> None:
        """After a command: hold where the aircraft is, unless a newer command has reserved its own way on."""
        if self.latest[0] == mine:
            self.book.hold(self.uav, self.here())

    # ---- the gated tools ----

    async def takeoff(self, args: dict[str, Any], context: ToolContext) -> Any:
        mine = self.start(context.tool)
        now = self.here()
        asked = float(args.get("altitude_m", 10.0))
        grant = await self.reserve(mine, context.tool, Point(north=now.north, east=now.east), asked_m=asked)
        try:
            await self.until(grant.go_s, mine, context.tool)
            result = await self.call("flight.takeoff", {**args, "altitude_m": grant.layer_m}, context, mine)
            await self.until(grant.trajectory.waypoints[-1][0], mine, context.tool)
            return result
        finally:
            self.settle(mine)

    async def fly_to(self, args: dict[str, Any], context: ToolContext) -> Any:
        mine = self.start(context.tool)
        goal = self.destination(args)
        if goal is None:
            return await self.call("flight.fly_to", args, context)  # the tool says what is wrong with it
        now = self.here()
        asked = args.get("alt_m")
        if now.horizontal_to(goal) < AT_M and (asked is None or abs(now.alt - float(asked)) < AT_M):
            self.book.hold(self.uav, now)  # already there: no leg, a hold
            return await self.call("flight.fly_to", args, context)
        grant = await self.reserve(mine, context.tool, goal, asked_m=None if asked is None else float(asked))
        try:
            await self.to_layer(mine, grant, context)
            return await self.across(mine, grant, goal, context)
        finally:
            self.settle(mine)

    async def land(self, args: dict[str, Any], context: ToolContext) -> Any:
        mine = self.start(context.tool)
        now = self.here()
        goal = self.destination(args) or Point(north=now.north, east=now.east)
        grant = await self.reserve(mine, context.tool, goal, land=True)
        try:
            await self.to_layer(mine, grant, context)
            await self.across(mine, grant, goal, context)
            return await self.call("flight.land", args, context, mine)
        finally:
            self.settle(mine)

    async def rtl(self, args: dict[str, Any], context: ToolContext) -> Any:
        mine = self.start(context.tool)
        home = Point(north=self.pad.north, east=self.pad.east)
        grant = await self.reserve(mine, context.tool, home, land=True)
        landed = False
        try:
            await self.to_layer(mine, grant, context)
            await self.across(mine, grant, home, context)
            result = await self.call("flight.land", {}, context, mine)
            landed = True
            return result
        finally:
            if landed:
                self.book.release(self.uav, "landed at home")
            else:
                self.settle(mine)

    async def hover(self, args: dict[str, Any], context: ToolContext) -> Any:
        self.start(context.tool)
        self.book.hold(self.uav, self.here())
        return await self.call("flight.hover", args, context)

    async def hold(self, args: dict[str, Any], context: ToolContext) -> Any:
        mine = self.start(context.tool)
        try:
            return await self.call("flight.hold", args, context)
        finally:
            self.settle(mine)

    async def refuse(self, args: dict[str, Any], context: ToolContext) -> Any:
        raise ToolError(f"{context.tool} flies a path the swarm's airspace cannot reserve: fly it as fly_to legs")


def gate_legs(
    registry: ToolRegistry,
    book: LegBook,
    uav: str,
    *,
    here: Callable[[], Point],
    origin: tuple[float, float],
    pad: Point,
    targets: Targets = lambda _: None,
    poll_s: float = 0.02,
    retry_s: float = 10.0,
    patience_s: float = 300.0,
) -> None:
    """Wrap ``uav``'s ``flight.*`` tools in ``registry`` (those registered) with the swarm's airspace: ``here`` is
    where the aircraft is in the swarm's frame (metres from ``origin``, the scene's home, latitude and longitude),
    ``pad`` its own home in that frame, ``targets`` where a world-model object is (latitude, longitude)."""
    gate = _Gate(registry, book, uav, here=here, origin=origin, pad=pad, targets=targets, poll_s=poll_s,
                 retry_s=retry_s, patience_s=patience_s)  # fmt: skip
    wrappers = {
        "flight.takeoff": gate.takeoff, "flight.fly_to": gate.fly_to, "flight.land": gate.land,
        "flight.rtl": gate.rtl, "flight.hover": gate.hover, "flight.hold": gate.hold,
        **dict.fromkeys(UNRESERVABLE, gate.refuse),
    }  # fmt: skip
    for name in (*wrappers, "flight.fly_to", "flight.land"):
        try:
            gate.original[name] = registry.get(name).handler
        except UnknownToolError:
            continue
    for name, wrapper in wrappers.items():
        if name in gate.original:
            spec = registry.get(name)
            registry.register(replace(spec, handler=wrapper, is_async=True), replace=True)


__all__ = ["AT_M", "LOST_POLL_S", "UNRESERVABLE", "gate_legs"]
