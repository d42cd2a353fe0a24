"""A swarm member's simulated vehicle: the in-process F450 (:class:`~agentic_core.run.backends.SimBackend`) ticked
on the swarm's one clock (:class:`~flight.mavlink.lockstep.Lockstep`) instead of a thread of its own, launched from
its own pad, and with PX4's multi-vehicle numbering (system id ``i + 1``; API stream to ``14540 + i`` when asked).

Its samples are handed on in the scene's frame (north/east from the scene's home, not from its own pad), so the
camera, the World Model, ``telemetry.jsonl`` and the swarm's separation all share one frame.
"""

from __future__ import annotations

from typing import Any

from flight.mavlink.lockstep import Lockstep
from flight.sim.environment import Home
from flight.tlog import TlogWriter, simulated_clock

from ..contracts import TelemetrySample
from ..contracts.geodesy import offset_position
from .backends import SimBackend

API_PORT = 14540
"""PX4 SITL's first API (MAVSDK) port: vehicle ``i`` streams to ``API_PORT + i``."""


def pad_home(home: Home, east_m: float) -> Home:
    """The home of a pad ``east_m`` east of ``home``."""
    lat, lon = offset_position(home.lat_deg, home.lon_deg, 0.0, east_m)
    return Home(lat_deg=lat, lon_deg=lon, alt_msl_m=home.alt_msl_m, heading_deg=home.heading_deg)


class LockstepBackend(SimBackend):
    """UAV ``index``'s vehicle on ``clock``, from a pad ``pad_east_m`` east of the scene's ``home``."""

    def __init__(
        self, *, clock: Lockstep, index: int, home: Home, pad_east_m: float, px4_ports: bool, **options: Any
    ) -> None:
        api = ("127.0.0.1", API_PORT + index) if px4_ports else None
        super().__init__(home=pad_home(home, pad_east_m), system_id=index + 1, api=api, **options)
        self.pad_east_m = pad_east_m
        self.clock = clock
        clock.add(self.vehicle)

    @property
    def alive(self) -> bool:
        """Whether its vehicle is still open (a killed UAV's is not)."""
        return self.vehicle.fileno() >= 0

    def _sample(self, sample: TelemetrySample) -> None:
        super()._sample(sample.model_copy(update={"east_m": sample.east_m + self.pad_east_m}))

    def start(self) -> None:
        """Open the flight log; the swarm's clock already ticks the vehicle."""
        if self.tlog_path is not None and self.tlog is None:
            self.tlog = TlogWriter(self.tlog_path)
            self.tlog.clock = simulated_clock(lambda: self.sim.time_s, self.tlog.last_us)
            self.vehicle.on_wire.append(self.tlog)


__all__ = ["API_PORT", "LockstepBackend", "pad_home"]
