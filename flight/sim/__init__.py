"""The simulated quadcopter: JSBSim's F450, a cascaded flight controller, a battery and an environment.

``Simulator`` is the entry point; it is stepped in lockstep by its caller (tests, the evaluation, or the MAVLink
vehicle's pacer). Nothing in ``flight.sim`` imports from ``agentic_core`` or ``tools``.
"""

from flight.geodesy import geodetic_to_ned, ned_to_geodetic
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
from flight.sim.jsbsim_model import DT, F450Model, ModelState
from flight.sim.simulator import GpsFix, Simulator, VehicleState
from flight.sim.snapshot import SimSnapshot, SnapshotError

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
