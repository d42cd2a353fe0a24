"""``agentic-uav swarm run --connect URL,URL,...``: the vehicles of a swarm that fly on their own (``agentic-uav sim``
in other processes, PX4 SITL, real aircraft), found before take-off and placed in the swarm's one frame.

Why: each vehicle reports positions from its own home; the swarm's sectors, separation and fused World Models are
north/east metres from the mission's origin (the scene's home). So every URL is asked first (:func:`find_fleet`,
all at once, a short timeout: a URL nobody answers is a clear error, not a hang), its vehicle named by its MAVLink
system id (two URLs that reach one vehicle are refused), its home read and checked near the mission's area, and its
samples are converted through WGS-84 into the swarm's frame (:class:`ConnectedBackend`).

Signing (``--signing-key``, one key for every link, as PX4 multi-vehicle setups use it): the probe signs what it
sends with the key and checks how each vehicle signs what it streams (a vehicle that requires signing still streams
its heartbeat and home). A vehicle that signs while the run has no key, signs with another key, or does not sign
while the run has one would refuse (or be refused by) every command: :class:`SigningMismatch` before anything flies.

>>> from flight.sim.environment import Home
>>> origin = Home(lat_deg=21.4133, lon_deg=39.8933)
>>> v = Vehicle(url="udp://127.0.0.1:18571", system_id=2, home=(21.4133, 39.89341, 300.0), origin=origin)
>>> v.uav, round(v.east_m, 1), round(v.north_m, 1)
('uav-2', 11.4, 0.0)
"""

from __future__ import annotations

import select
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from flight.sim.environment import Home

from ..contracts import TelemetrySample
from ..contracts.errors import InputError
from ..contracts.geodesy import local_offset
from ..contracts.polygon import outside_by
from .backends import LinkBackend, SampleHook
from .link_probe import ASK_EVERY_S, Probe, SigningMismatch, VehicleUnreachable, parse_link

_Probe = Probe  # the probe's name here before it moved to link_probe

PROBE_TIMEOUT_S = 3.0
"""How long a URL has to answer with a heartbeat and its home before the swarm run gives up on it."""
FAR_M = 2_000.0
"""A vehicle whose home lies farther than this outside the mission's area is refused."""


@dataclass(frozen=True)
class Vehicle:
    """A connected vehicle: where it is reached, its MAVLink system id, its home, and that home in the swarm's frame."""

    url: str
    system_id: int
    home: tuple[float, float, float]
    """Latitude, longitude (degrees), altitude above mean sea level (m)."""
    origin: Home

    @property
    def uav(self) -> str:
        """Its name in the swarm: ``uav-<system id>``."""
        return f"uav-{self.system_id}"

    @property
    def north_m(self) -> float:
        return local_offset(self.origin.lat_deg, self.origin.lon_deg, self.home[0], self.home[1])[0]

    @property
    def east_m(self) -> float:
        return local_offset(self.origin.lat_deg, self.origin.lon_deg, self.home[0], self.home[1])[1]


def _probe_all(
    urls: Sequence[str], timeout_s: float, signing_key: bytes | None = None
) -> list[tuple[int, tuple[float, float, float]]]:
    """Every URL's system id and home, all asked at once; :class:`VehicleUnreachable` for the first silent one,
    :class:`SigningMismatch` for the first whose link is not signed as ``signing_key`` says."""
    probes = [Probe(u, signing_key) for u in urls]
    try:
        deadline = time.monotonic() + timeout_s
        next_ask = 0.0
        while not all(p.answered for p in probes) and (now := time.monotonic()) < deadline:
            if now >= next_ask:
                for probe in probes:
                    probe.ask()
                next_ask = now + ASK_EVERY_S
            readable, _, _ = select.select([p.sock for p in probes], [], [], min(ASK_EVERY_S, deadline - now))
            for probe in probes:
                if probe.sock in readable:
                    probe.read()
        for probe in probes:
            if probe.system_id is None:
                raise VehicleUnreachable(f"--connect {probe.url}: no vehicle answered in {timeout_s:g} s")
            if (why := probe.mismatch()) is not None:
                raise SigningMismatch(why)
            if probe.home is None:
                raise VehicleUnreachable(
                    f"--connect {probe.url}: the vehicle answered but never said where its home is"
                )
        return [(p.system_id, p.home) for p in probes if p.system_id is not None and p.home is not None]
    finally:
        for probe in probes:
            probe.sock.close()


def find_fleet(
    urls: Sequence[str],
    origin: Home,
    area: Sequence[tuple[float, float]],
    *,
    timeout_s: float = PROBE_TIMEOUT_S,
    signing_key: bytes | None = None,
) -> list[Vehicle]:
    """Every URL's vehicle, ordered by system id; :class:`VehicleUnreachable` for a URL that does not answer,
    :class:`SigningMismatch` for a vehicle not signing as ``signing_key`` says (None: no signing), :class:`InputError`
    for two URLs that reach one vehicle or a vehicle far from ``area`` (latitude, longitude)."""
    for url in urls:
        parse_link(url)  # a malformed URL is the user's to fix before anyone is asked
    found = _probe_all(urls, timeout_s, signing_key)
    fleet: dict[int, Vehicle] = {}
    for url, (system_id, home) in zip(urls, found, strict=True):
        if system_id in fleet:
            raise InputError(
                f"--connect {fleet[system_id].url} and {url}: the same vehicle (system id {system_id}); "
                "give each vehicle once (PX4's instance i has system id i+1)"
            )
        nearest = outside_by((0.0, 0.0), [local_offset(home[0], home[1], lat, lon) for lat, lon in area])
        if nearest > FAR_M:
            raise InputError(
                f"--connect {url}: the vehicle (system id {system_id}) is {nearest / 1000:.1f} km from the mission's "
                f"area (home {home[0]:.6f}, {home[1]:.6f}); at most {FAR_M / 1000:g} km"
            )
        fleet[system_id] = Vehicle(url=url, system_id=system_id, home=home, origin=origin)
    return [fleet[s] for s in sorted(fleet)]


class ConnectedBackend(LinkBackend):
    """A connected vehicle whose samples every hook gets in the swarm's frame: north/east from ``origin`` through
    WGS-84 (its own home is its own origin); altitude stays above its own home, as its commands are."""

    def __init__(
        self, vehicle: Vehicle, *, camera_hz: float = 30.0, tlog: Path | None = None, signing_key: bytes | None = None
    ) -> None:
        super().__init__(vehicle.url, camera_hz=camera_hz, tlog=tlog)
        self.signing_key = signing_key  # the run's client signs with it, as a single run's does
        self.probe_first = False  # find_fleet has probed it already
        self.run_clock = None  # the swarm puts its connected vehicles on its own clock
        self.vehicle = vehicle

    def in_swarm_frame(self, sample: TelemetrySample) -> TelemetrySample:
        """``sample`` with its north/east from the swarm's origin."""
        origin = self.vehicle.origin
        north, east = local_offset(origin.lat_deg, origin.lon_deg, sample.lat_deg, sample.lon_deg)
        return sample.model_copy(update={"north_m": north, "east_m": east})

    def on_sample(self, hook: SampleHook) -> None:
        super().on_sample(lambda sample: hook(self.in_swarm_frame(sample)))


__all__ = [
    "FAR_M",
    "PROBE_TIMEOUT_S",
    "ConnectedBackend",
    "SigningMismatch",
    "Vehicle",
    "VehicleUnreachable",
    "find_fleet",
]
