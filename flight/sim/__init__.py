"""The simulated quadcopter: JSBSim's F450, a cascaded flight controller, a battery and an environment.

``Simulator`` is the entry point; it is stepped in lockstep by its caller (tests, the evaluation, or the MAVLink
vehicle's pacer). Nothing in ``flight.sim`` imports from ``agentic_core`` or ``tools``.
"""

import importlib
from typing import TYPE_CHECKING, Any

from agentic_core.contracts.geodesy import geodetic_to_ned, ned_to_geodetic
from flight.sim.battery import Battery, BatteryConfig, cell_ocv
from flight.sim.controller import (
    ControlOutput,
    FlightController,
    Gains,
    GoToPosition,
    HoldPosition,
    Land,
    Limits,
    Setpoint,
    VelocitySetpoint,
)
from flight.sim.environment import Environment, GpsNoise, GpsNoiseSettings, Home, WindSettings

if TYPE_CHECKING:
    from flight.sim.jsbsim_model import DT, F450Model, ModelState
    from flight.sim.simulator import GpsFix, Simulator, VehicleState
    from flight.sim.snapshot import SimSnapshot, SnapshotError

_LAZY = {
    "DT": "flight.sim.jsbsim_model",
    "F450Model": "flight.sim.jsbsim_model",
    "ModelState": "flight.sim.jsbsim_model",
    "GpsFix": "flight.sim.simulator",
    "Simulator": "flight.sim.simulator",
    "VehicleState": "flight.sim.simulator",
    "SimSnapshot": "flight.sim.snapshot",
    "SnapshotError": "flight.sim.snapshot",
}
"""Loaded on first use, so reading a scene file (``flight.sim.scene_file``) does not load JSBSim."""


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


__all__ = [
    "DT",
    "Battery",
    "BatteryConfig",
    "ControlOutput",
    "Environment",
    "F450Model",
    "FlightController",
    "Gains",
    "GoToPosition",
    "GpsFix",
    "GpsNoise",
    "GpsNoiseSettings",
    "HoldPosition",
    "Home",
    "Land",
    "Limits",
    "ModelState",
    "Setpoint",
    "SimSnapshot",
    "Simulator",
    "SnapshotError",
    "VehicleState",
    "VelocitySetpoint",
    "WindSettings",
    "cell_ocv",
    "geodetic_to_ned",
    "ned_to_geodetic",
]
