"""The vehicle's parameters, named and encoded as PX4 names and encodes them.

Why: clients tune the vehicle through the parameter protocol (PARAM_REQUEST_LIST 21, PARAM_REQUEST_READ 20,
PARAM_SET 23, each answered with PARAM_VALUE 22), and MAVSDK's ``action.takeoff`` writes ``MIS_TAKEOFF_ALT``
before sending NAV_TAKEOFF with NaN altitude, so the names must be PX4's.

Facts relied on:

* PX4 packs integer parameters *bytewise*: the ``float`` field carries the int32's four bytes, not its value cast to
  float (mavlink.io, "Parameter protocol — parameter encoding"; AUTOPILOT_VERSION advertises it with
  MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE = 16). MAV_PARAM_TYPE_INT32 = 6, MAV_PARAM_TYPE_REAL32 = 9.
* ``param_id`` is at most 16 characters, NUL-padded when shorter.
* Defaults as documented in PX4's parameter reference: MIS_TAKEOFF_ALT 2.5 m, RTL_RETURN_ALT 60 m, GF_ACTION 2
  (hold; values 0 none, 1 warning, 2 hold, 3 return, 4 terminate, 5 land, checked in PX4's ``geofence_params.c``
  and the ``GeofenceResult`` uORB message of the v1.14 user guide), BAT_LOW_THR 0.15, BAT_CRIT_THR 0.07,
  COM_DL_LOSS_T 10 s (``commander_params.c``), COM_OF_LOSS_T 1.0 s (``commander_params.c`` of PX4 1.14; older
  releases had 0 with a hard-coded 0.5 s), MPC_XY_CRUISE 5 m/s (from memory, not re-checked). NAV_DLL_ACT takes
  PX4's values (0 disabled, 1 hold, 2 return, 3 land, 5 terminate, 6 disarm; ``commander_params.c``).
* **Our defaults, not PX4's**: GF_MAX_HOR_DIST 1500 m and GF_MAX_VER_DIST 120 m (PX4: 0, no fence) so that a
  vehicle nobody configured still has a fence (120 m is the usual regulatory ceiling for small drones);
  NAV_DLL_ACT 2, return (PX4: 0, disabled) because the issue asks for a link-loss return.
* ``SYS_FAILURE_EN`` (0 default: failure injection refused) and ``GF_PREDICT`` are PX4's names (PX4 user guide,
  "System Failure Injection"; ``geofence_params.c``). PX4's GF_PREDICT predicts a breach and triggers
  ``GF_ACTION`` early; ours clamps offboard velocity setpoints so the vehicle stops at the fence
  (:mod:`flight.mavlink.fence_predict`).
* **Ours, not PX4's**: ``GF_MIN_ALT``, the floor: targets (reposition, offboard positions, mission waypoints)
  lower than this above home are refused, take-off and landing excepted, and offboard descent stops at it.
  PX4 has no such floor (``LNDMC_ALT_MAX`` is a land-detector limit, not a target check); the name follows the
  ``GF_`` family, so setting it re-checks the stored mission like the other fence parameters.
* The accepted ranges are ours. Only these parameters exist. What reads them: :mod:`flight.mavlink.failsafe`
  (GF_*, BAT_*_THR, COM_DL_LOSS_T, NAV_DLL_ACT), :mod:`flight.mavlink.navigator` (the rest, and the fence for
  commands).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_PARAM_TYPE_INT32,
    MAV_PARAM_TYPE_REAL32,
)


@dataclass(frozen=True, slots=True)
class ParamSpec:
    """A parameter's name, wire type, default and accepted range (inclusive)."""

    name: str
    param_type: int
    default: float
    minimum: float
    maximum: float
    description: str


PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec("MIS_TAKEOFF_ALT", MAV_PARAM_TYPE_REAL32, 2.5, 0.0, 80.0, "Take-off altitude above home (m)"),
    ParamSpec("RTL_RETURN_ALT", MAV_PARAM_TYPE_REAL32, 60.0, 0.0, 150.0, "Return altitude above home (m)"),
    ParamSpec("GF_MAX_HOR_DIST", MAV_PARAM_TYPE_REAL32, 1500.0, 0.0, 10000.0, "Geofence radius from home (m, 0 off)"),
    ParamSpec("GF_MAX_VER_DIST", MAV_PARAM_TYPE_REAL32, 120.0, 0.0, 10000.0, "Geofence height above home (m, 0 off)"),
    ParamSpec("GF_ACTION", MAV_PARAM_TYPE_INT32, 2, 0, 5, "Geofence breach action (0 none … 3 RTL, 5 land)"),
    ParamSpec("BAT_LOW_THR", MAV_PARAM_TYPE_REAL32, 0.15, 0.12, 0.5, "Low battery threshold (fraction)"),
    ParamSpec("BAT_CRIT_THR", MAV_PARAM_TYPE_REAL32, 0.07, 0.05, 0.25, "Critical battery threshold (fraction)"),
    ParamSpec("COM_DL_LOSS_T", MAV_PARAM_TYPE_INT32, 10, 5, 300, "Data-link loss timeout (s)"),
    ParamSpec("NAV_DLL_ACT", MAV_PARAM_TYPE_INT32, 2, 0, 6, "Data-link loss action (0 off, 1 hold, 2 RTL, 3 land)"),
    ParamSpec("COM_OF_LOSS_T", MAV_PARAM_TYPE_REAL32, 1.0, 0.1, 60.0, "Offboard setpoint loss timeout (s)"),
    ParamSpec("MPC_XY_CRUISE", MAV_PARAM_TYPE_REAL32, 5.0, 3.0, 20.0, "Horizontal cruise speed (m/s)"),
    ParamSpec("GF_MIN_ALT", MAV_PARAM_TYPE_REAL32, 2.0, 0.0, 1000.0, "Floor for targets above home (m, 0 off)"),
    ParamSpec("GF_PREDICT", MAV_PARAM_TYPE_INT32, 1, 0, 1, "Stop offboard velocity before the fence (1 on)"),
    ParamSpec("SYS_FAILURE_EN", MAV_PARAM_TYPE_INT32, 0, 0, 1, "Allow MAV_CMD_INJECT_FAILURE (1 on)"),
)


def encode_value(value: float, param_type: int) -> float:
    """The PARAM_VALUE/PARAM_SET float field for ``value`` (bytewise for INT32)."""
    if param_type == MAV_PARAM_TYPE_INT32:
        return float(struct.unpack("<f", struct.pack("<i", int(value)))[0])
    return float(value)


def decode_value(field: float, param_type: int) -> float:
    """The value a PARAM_SET/PARAM_VALUE float field carries for a parameter of ``param_type``."""
    if param_type == MAV_PARAM_TYPE_INT32:
        return float(struct.unpack("<i", struct.pack("<f", field))[0])
    return float(field)


class ParamStore:
    """The current values, by name, in :data:`PARAMS` order (which gives ``param_index``)."""

    def __init__(self, overrides: dict[str, float] | None = None) -> None:
        self.specs = {p.name: p for p in PARAMS}
        self.names = [p.name for p in PARAMS]
        self._values = {p.name: float(p.default) for p in PARAMS}
        self.values: Mapping[str, float] = MappingProxyType(self._values)
        """The current values by name, read-only (``store.values[name]`` is ``store[name]`` without a method
        call, for the checks made every tick)."""
        for name, value in (overrides or {}).items():
            if not self.set(name, value):
                raise ValueError(f"bad parameter override {name}={value}")

    def __len__(self) -> int:
        return len(self.names)

    def __getitem__(self, name: str) -> float:
        return self._values[name]

    def __contains__(self, name: object) -> bool:
        return name in self._values

    def index(self, name: str) -> int:
        return self.names.index(name)

    def set(self, name: str, value: float) -> bool:
        """Set ``name`` to ``value`` (rounded for integers). False (unchanged) if unknown, NaN or out of range."""
        spec = self.specs.get(name)
        if spec is None or not math.isfinite(value) or not spec.minimum <= value <= spec.maximum:
            return False
        if spec.param_type == MAV_PARAM_TYPE_INT32:
            value = float(round(value))
        else:
            value = float(struct.unpack("<f", struct.pack("<f", value))[0])  # what a float32 can hold
        self._values[name] = value
        return True
