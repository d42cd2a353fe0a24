"""Short wind-gust flights of the simulated F450 and what their telemetry says: tracking error, energy, jerk.

A flight: take off to 10 m, fly to a point ``leg_m`` north and hold there, in a steady wind with gusts drawn from
``seed``; :class:`TelemetrySample` rows at 10 Hz, as ``telemetry.jsonl`` holds them. :func:`costs` reads such rows
(a run's own ``telemetry.jsonl`` too): the RMS horizontal distance from the target once ``settle_s`` has passed
since the leg began, the battery spent, and the mean squared horizontal jerk.

>>> rows = fly(Gains(), seed=1, hold_s=6.0)
>>> c = costs(rows, TARGET, start_s=rows[0].time_s)
>>> 0.0 < c.tracking_m < 2.0, c.energy_pct > 0.0, c.jerk > 0.0
(True, True, True)
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agentic_core.contracts.telemetry import TelemetrySample
from flight.sim.controller import Gains
from flight.sim.environment import Environment, WindSettings
from flight.sim.simulator import Simulator

ALT_M = 10.0
LEG_M = 25.0
TARGET = (LEG_M, 0.0)
SAMPLE_HZ = 10.0
SCALES = (0.5, 1.0, 10.0)
"""What costs one unit of score: metres of tracking error, battery percent, mean squared jerk (m²/s⁶)."""


@dataclass(frozen=True)
class Costs:
    """What one flight's telemetry says (lower is better for each)."""

    tracking_m: float
    energy_pct: float
    jerk: float

    def score(self) -> float:
        """One number, lower is better: a 0.5 m tracking error costs as much as 1 % of the battery or a mean squared
        jerk of 10 m²/s⁶ (:data:`SCALES`)."""
        return self.tracking_m / SCALES[0] + self.energy_pct / SCALES[1] + self.jerk / SCALES[2]


def wind(seed: int) -> WindSettings:
    """A gusty day: 3–6 m/s from a direction drawn from ``seed``, gusts of 1.5 m/s."""
    rng = np.random.default_rng([seed, 31])
    return WindSettings.from_direction(float(rng.uniform(3.0, 6.0)), float(rng.uniform(0.0, 360.0)), 1.5, 2.0)


def _sample(sim: Simulator) -> TelemetrySample:
    s = sim.state()
    return TelemetrySample(time_s=s.time_s, lat_deg=s.lat_deg, lon_deg=s.lon_deg, alt_m=-s.down_m,
                           north_m=s.north_m, east_m=s.east_m, down_m=s.down_m, vn_mps=s.vn_mps, ve_mps=s.ve_mps,
                           vd_mps=s.vd_mps, roll_deg=math.degrees(s.roll_rad), pitch_deg=math.degrees(s.pitch_rad),
                           yaw_deg=math.degrees(s.yaw_rad) % 360.0, battery_pct=s.battery_pct,
                           armed=s.armed)  # fmt: skip


def fly(gains: Gains, seed: int, hold_s: float = 10.0) -> list[TelemetrySample]:
    """One flight's telemetry from the start of its leg: the leg and ``hold_s`` of holding at its end."""
    sim = Simulator(Environment(wind=wind(seed)), gains=gains, seed=seed)
    sim.arm()
    sim.takeoff(ALT_M)
    sim.run_until(lambda s: abs(s.down_m + ALT_M) < 0.5, timeout_s=20.0)
    sim.goto(TARGET[0], TARGET[1], -ALT_M)
    rows = []
    for _ in range(round((LEG_M / 5.0 + hold_s) * SAMPLE_HZ)):
        rows.append(_sample(sim))
        sim.run_for(1.0 / SAMPLE_HZ)
    return rows


def costs(rows: Sequence[TelemetrySample], target: tuple[float, float], start_s: float, settle_s: float = 6.0
          ) -> Costs:  # fmt: skip
    """The costs of a flight from its telemetry (``start_s``: when the leg to ``target`` began)."""
    if len(rows) < 4:
        raise ValueError("too few telemetry samples to judge a flight (need 4 or more)")
    t = np.array([r.time_s for r in rows])
    settled = [r for r in rows if r.time_s >= start_s + settle_s] or list(rows[-1:])
    err = [math.hypot(r.north_m - target[0], r.east_m - target[1]) for r in settled]
    v = np.array([[r.vn_mps, r.ve_mps] for r in rows])
    dt = np.diff(t)[:, None]
    accel = np.diff(v, axis=0) / dt
    jerk = np.diff(accel, axis=0) / dt[1:]
    battery = [r.battery_pct for r in rows if r.battery_pct is not None]
    return Costs(tracking_m=float(np.sqrt(np.mean(np.square(err)))),
                 energy_pct=float(battery[0] - battery[-1]) if battery else 0.0,
                 jerk=float(np.mean(np.sum(jerk**2, axis=1))))  # fmt: skip


def write_telemetry(rows: Sequence[TelemetrySample], path: Path) -> None:
    """``rows`` as a run writes them (one JSON object a line)."""
    path.write_text("".join(r.model_dump_json() + "\n" for r in rows), encoding="utf-8")


def read_telemetry(path: Path) -> list[TelemetrySample]:
    """A ``telemetry.jsonl`` back (a run's, or :func:`write_telemetry`'s)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    return [TelemetrySample.model_validate(json.loads(line)) for line in lines if line.strip()]


__all__ = ["TARGET", "Costs", "costs", "fly", "read_telemetry", "wind", "write_telemetry"]
