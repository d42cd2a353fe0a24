"""The MAVLink vehicle: the simulated F450 on UDP, speaking MAVLink 2 the way PX4 SITL does.

:class:`MavlinkVehicle` (in :mod:`flight.mavlink.vehicle`) owns the socket, the message loop and the streams;
:mod:`flight.mavlink.commands` answers COMMAND_LONG/COMMAND_INT; :mod:`flight.mavlink.navigator` flies the PX4
modes on the :class:`~flight.sim.Simulator`; :mod:`flight.px4` encodes PX4 modes;
:mod:`flight.mavlink.params` holds the parameters; :mod:`flight.mavlink.failsafe` enforces the geofence, battery and
data-link failsafes, with :mod:`flight.mavlink.geofence` (the parameters' cylinder and uploaded fence areas);
:mod:`flight.mavlink.offboard` decodes offboard setpoints; :mod:`flight.mavlink.telemetry` builds the streamed
messages. Missions: :mod:`flight.mavlink.mission` (plan store, upload/download state machines),
:mod:`flight.mavlink.mission_items` (what an item may be, on the wire and stored),
:mod:`flight.mavlink.mission_runner` (Mission mode, MISSION_START, DO_SET_MISSION_CURRENT) and
:mod:`flight.mavlink.mission_service` (the three wired to the link); :mod:`flight.mavlink.snapshot` saves and
restores the vehicle's state. Each module's docstring names the MAVLink facts
it relies on.
"""

from flight.mavlink.commands import CommandOutcome, CommandRequest, handle_command
from flight.mavlink.failsafe import Failsafes
from flight.mavlink.geofence import Geofence
from flight.mavlink.mission import MissionProtocol, MissionStore
from flight.mavlink.mission_items import StoredItem
from flight.mavlink.mission_runner import MissionRunner
from flight.mavlink.mission_service import MissionService
from flight.mavlink.navigator import CommandDenied, Navigator, RtlPhase
from flight.mavlink.offboard import OffboardSetpoint, SetpointRejected
from flight.mavlink.params import PARAMS, ParamSpec, ParamStore, decode_value, encode_value
from flight.mavlink.snapshot import VehicleSnapshot
from flight.mavlink.vehicle import DEFAULT_RATES_HZ, LinkStats, MavlinkVehicle
from flight.px4 import AutoSubMode, FlightMode, MainMode, base_mode, decode_custom_mode, encode_custom_mode

__all__ = [
    "DEFAULT_RATES_HZ",
    "PARAMS",
    "AutoSubMode",
    "CommandDenied",
    "CommandOutcome",
    "CommandRequest",
    "Failsafes",
    "FlightMode",
    "Geofence",
    "LinkStats",
    "MainMode",
    "MavlinkVehicle",
    "MissionProtocol",
    "MissionRunner",
    "MissionService",
    "MissionStore",
    "Navigator",
    "OffboardSetpoint",
    "ParamSpec",
    "ParamStore",
    "RtlPhase",
    "SetpointRejected",
    "StoredItem",
    "VehicleSnapshot",
    "base_mode",
    "decode_custom_mode",
    "decode_value",
    "encode_custom_mode",
    "encode_value",
    "handle_command",
]
