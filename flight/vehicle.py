"""The agent's side of the link: an asyncio client that flies a PX4-like vehicle over MAVLink 2 on UDP.

:class:`VehicleClient` connects (waits for a HEARTBEAT, with a timeout), keeps the vehicle's telemetry current and
offers what a mission needs: :meth:`~VehicleClient.arm`, :meth:`~VehicleClient.takeoff`,
:meth:`~VehicleClient.goto`, :meth:`~VehicleClient.goto_local`, :meth:`~VehicleClient.orbit`,
:meth:`~VehicleClient.hover`, :meth:`~VehicleClient.hold`, :meth:`~VehicleClient.land`,
:meth:`~VehicleClient.rtl`, :meth:`~VehicleClient.deploy_payload` (each returning a :class:`FlightResult` built from
the COMMAND_ACK *and* the state observed afterwards), and the mission protocol:
:meth:`~VehicleClient.upload_mission`, :meth:`~VehicleClient.download_mission`, :meth:`~VehicleClient.clear_mission`
(each returning a :class:`MissionResult`), :meth:`~VehicleClient.start_mission` and
:meth:`~VehicleClient.wait_mission`; safety set-up: :meth:`~VehicleClient.upload_fence` (fence items and altitude
limits, read back; a :class:`FenceResult`) and :meth:`~VehicleClient.inject_failure`; for a consumer on another
thread, :meth:`~VehicleClient.set_stream_rates` and
:meth:`~VehicleClient.on_sample` (a callback per :class:`~agentic_core.contracts.telemetry.TelemetrySample`).
Refusals and silences are results, never exceptions; every wait has a wall-clock timeout, so no call hangs when the
vehicle stops answering.

This module is the public face; the parts live in :mod:`flight.client` (link and reader thread, telemetry, waiting,
commands, operations, flight actions, missions, results), each saying which MAVLink facts it relies on.
"""

from __future__ import annotations

from flight.client.actions import FORCE_MAGIC, GRIPPER_ACTION_RELEASE, FlightActions
from flight.client.commands import DENIAL_TEXT_WAIT_S
from flight.client.core import ACK_ATTEMPTS, ACK_TIMEOUT_S
from flight.client.link import Address, VehicleConnectionError, parse_address
from flight.client.mission_items import MISSION_TYPE_IDS, MissionItem, MissionType
from flight.client.operations import FLYING_MODES
from flight.client.results import (
    COMMAND_NAMES,
    MAV_RESULT_NAMES,
    CommandStatus,
    FlightResult,
    MissionResult,
    TransferStatus,
)
from flight.client.safety import FenceResult, SafetyClient
from flight.client.streams import CAMERA_STREAMS, StreamsClient
from flight.client.telemetry import (
    LANDED_STATES,
    LINK_TIMEOUT_S,
    PX4_MODES,
    STATUSTEXT_LEN,
    UINT16_MAX,
    LandedState,
    MissionState,
    Telemetry,
    TelemetrySubscription,
)


class VehicleClient(FlightActions, SafetyClient, StreamsClient):
    """A MAVLink client for one vehicle. Make it with :meth:`connect`; close it (or ``async with``) when done.

    Addresses: ``"HOST:PORT"``, ``"udpout:HOST:PORT"`` or ``(host, port)`` send to the vehicle; ``"udpin:HOST:PORT"``
    listens there (PX4 SITL sends to 127.0.0.1:14540 for APIs)."""


__all__ = [
    "ACK_ATTEMPTS",
    "ACK_TIMEOUT_S",
    "CAMERA_STREAMS",
    "COMMAND_NAMES",
    "DENIAL_TEXT_WAIT_S",
    "FLYING_MODES",
    "FORCE_MAGIC",
    "GRIPPER_ACTION_RELEASE",
    "LANDED_STATES",
    "LINK_TIMEOUT_S",
    "MAV_RESULT_NAMES",
    "MISSION_TYPE_IDS",
    "PX4_MODES",
    "STATUSTEXT_LEN",
    "UINT16_MAX",
    "Address",
    "CommandStatus",
    "FenceResult",
    "FlightResult",
    "LandedState",
    "MissionItem",
    "MissionResult",
    "MissionState",
    "MissionType",
    "Telemetry",
    "TelemetrySubscription",
    "TransferStatus",
    "VehicleClient",
    "VehicleConnectionError",
    "parse_address",
]
