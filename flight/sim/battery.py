"""A LiPo battery for the simulated F450: capacity, an open-circuit voltage curve and drain from the motors.

JSBSim's F450 has no battery, so the pack is modelled here and integrated alongside the flight model.

Model (constants in :class:`BatteryConfig`):

* **Open-circuit voltage** per cell is a piecewise-linear curve over state of charge (:data:`LIPO_OCV_CURVE`):
  4.20 V full, a long plateau around 3.7–3.9 V, and a knee below 10 % down to 3.27 V at empty — the usual
  shape of a LiPo cell discharged at a moderate rate. The pack's open-circuit voltage is ``cells ×`` that.
* **Terminal voltage** = open-circuit voltage − ``current × internal_resistance_ohm`` (sag under load).
* **Current** is estimated from the four ESC commands ``u_i ∈ [0, 1]``: each motor's shaft power is
  ``motor_power_max_w · u_i^power_exponent`` (290 W and 2.5 fit the shaft power of the model's DJI E305 motor and
  9450 propeller between throttle 0.4 and 0.7), electrical power is shaft power over ``efficiency``, and the pack
  current is electrical power over the terminal voltage plus a constant ``avionics_current_a``. At hover (about
  0.41 throttle) a 4S pack delivers about 12 A, about 20 minutes from 5000 mAh.
* **Drain**: charge used is the current integrated over time (explicit Euler at each update), so state of charge
  falls monotonically, and faster at higher throttle.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass

LIPO_OCV_CURVE: tuple[tuple[float, float], ...] = (
    (0.00, 3.27),
    (0.05, 3.61),
    (0.10, 3.69),
    (0.15, 3.71),
    (0.20, 3.73),
    (0.25, 3.75),
    (0.30, 3.77),
    (0.35, 3.79),
    (0.40, 3.80),
    (0.45, 3.82),
    (0.50, 3.84),
    (0.55, 3.85),
    (0.60, 3.87),
    (0.65, 3.91),
    (0.70, 3.95),
    (0.75, 3.98),
    (0.80, 4.02),
    (0.85, 4.08),
    (0.90, 4.11),
    (0.95, 4.15),
    (1.00, 4.20),
)
"""(state of charge, open-circuit cell voltage in V), increasing in both."""
_SOC = [p[0] for p in LIPO_OCV_CURVE]
_OCV = [p[1] for p in LIPO_OCV_CURVE]


def cell_ocv(soc: float) -> float:
    """Open-circuit voltage (V) of one LiPo cell at a state of charge in ``[0, 1]`` (clamped)."""
    if soc <= 0.0:
        return _OCV[0]
    if soc >= 1.0:
        return _OCV[-1]
    i = bisect.bisect_right(_SOC, soc)
    s0, s1, v0, v1 = _SOC[i - 1], _SOC[i], _OCV[i - 1], _OCV[i]
    return v0 + (v1 - v0) * (soc - s0) / (s1 - s0)


@dataclass(frozen=True, slots=True)
class BatteryConfig:
    """A LiPo pack and the power train it feeds. The defaults are a 4S 5000 mAh pack on the F450."""

    cells: int = 4
    capacity_mah: float = 5000.0
    internal_resistance_ohm: float = 0.02
    motor_power_max_w: float = 290.0
    power_exponent: float = 2.5
    efficiency: float = 0.75
    avionics_current_a: float = 0.5
    initial_soc: float = 1.0

    def __post_init__(self) -> None:
        if self.cells not in (3, 4, 6):
            raise ValueError(f"cells must be 3, 4 or 6, not {self.cells}")
        if self.capacity_mah <= 0:
            raise ValueError("capacity_mah must be positive")
        if not 0.0 <= self.initial_soc <= 1.0:
            raise ValueError("initial_soc must be in [0, 1]")


class Battery:
    """The pack's state: charge used, current and terminal voltage."""

    def __init__(self, config: BatteryConfig | None = None) -> None:
        self.config = config or BatteryConfig()
        self.used_mah = (1.0 - self.config.initial_soc) * self.config.capacity_mah
        self.soc_cap: float | None = None
        """An injected failure (:mod:`flight.mavlink.failures`): the pack reports at most this state of charge, and
        its voltage follows; None (the default) reports the true charge."""
        self.current_a = self.config.avionics_current_a
        self.voltage_v = self.open_circuit_voltage() - self.current_a * self.config.internal_resistance_ohm

    @property
    def soc(self) -> float:
        """State of charge in ``[0, 1]`` (at most :attr:`soc_cap`)."""
        soc = max(0.0, 1.0 - self.used_mah / self.config.capacity_mah)
        cap = self.soc_cap
        return soc if cap is None or soc < cap else max(0.0, cap)

    @property
    def percent(self) -> float:
        """Remaining charge in percent."""
        return 100.0 * self.soc

    @property
    def depleted(self) -> bool:
        return self.soc <= 0.0

    def open_circuit_voltage(self) -> float:
        return self.config.cells * cell_ocv(self.soc)

    def estimate_current(self, motor_throttles: Sequence[float]) -> float:
        """Pack current (A) for the given ESC commands at the present terminal voltage."""
        c = self.config
        p_max, exponent = c.motor_power_max_w, c.power_exponent
        shaft_w = 0.0
        for u in motor_throttles:
            if u > 0.0:
                shaft_w += p_max * (u if u < 1.0 else 1.0) ** exponent
        volts, floor = self.voltage_v, 0.5 * c.cells * _OCV[0]
        return c.avionics_current_a + shaft_w / c.efficiency / (floor if floor > volts else volts)

    def update(self, motor_throttles: Sequence[float], dt: float) -> None:
        """Draw the current for ``dt`` seconds of the given ESC commands and update the voltage."""
        c = self.config
        current = self.current_a = self.estimate_current(motor_throttles)
        used = self.used_mah + current * dt / 3.6
        used = self.used_mah = used if used < c.capacity_mah else c.capacity_mah
        soc = 1.0 - used / c.capacity_mah  # :attr:`soc` and :meth:`open_circuit_voltage`, without two calls per tick
        if self.soc_cap is not None and soc > self.soc_cap:
            soc = self.soc_cap
        self.voltage_v = c.cells * cell_ocv(soc if soc > 0.0 else 0.0) - current * c.internal_resistance_ohm
