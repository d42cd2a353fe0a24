"""What the client's actions return: :class:`FlightResult` for commands and flights, :class:`MissionResult` for
mission transfers, and the names of the MAVLink results they quote.

Why: the agent (and the ``flight.*`` tools over it) must tell "done", "refused and why" and "no answer" apart
without parsing text, so every action returns one of these models, never raises for a refusal, and carries the
telemetry observed at its end.

Facts relied on (MAVLink ``common.xml`` through pymavlink's ``dialects/v20/common.py``): MAV_RESULT ACCEPTED 0,
TEMPORARILY_REJECTED 1, DENIED 2, UNSUPPORTED 3, FAILED 4, IN_PROGRESS 5, CANCELLED 6; MAV_MISSION_RESULT names
are taken from the dialect's enum table.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field
from pymavlink.dialects.v20 import common as mavlink2

from flight.client.mission_items import MissionItem, MissionType
from flight.client.telemetry import Telemetry

CommandStatus = Literal["ok", "denied", "timeout", "unsupported", "failed"]
TransferStatus = Literal["ok", "denied", "timeout", "failed"]

MAV_RESULT_NAMES = {0: "ACCEPTED", 1: "TEMPORARILY_REJECTED", 2: "DENIED", 3: "UNSUPPORTED", 4: "FAILED"}
MAV_RESULT_NAMES |= {5: "IN_PROGRESS", 6: "CANCELLED"}

COMMAND_NAMES = {
    20: "NAV_RETURN_TO_LAUNCH",
    21: "NAV_LAND",
    22: "NAV_TAKEOFF",
    34: "DO_ORBIT",
    176: "DO_SET_MODE",
    192: "DO_REPOSITION",
    211: "DO_GRIPPER",
    224: "DO_SET_MISSION_CURRENT",
    300: "MISSION_START",
    400: "COMPONENT_ARM_DISARM",
    410: "GET_HOME_POSITION",
}


def mission_result_name(result: int) -> str:
    """``MAV_MISSION_ACCEPTED``, ``MAV_MISSION_ERROR``, ... for a MAV_MISSION_RESULT (its number if unknown)."""
    entry = mavlink2.enums["MAV_MISSION_RESULT"].get(result)
    return str(entry.name) if entry is not None else f"MAV_MISSION_RESULT_{result}"


class FlightResult(BaseModel):
    """The outcome of one action: the vehicle's answer and what was then observed."""

    model_config = ConfigDict(frozen=True)

    action: str
    status: CommandStatus
    reason: str | None = Field(default=None, description="why it was refused or did not complete; notes otherwise")
    reached: bool | None = Field(default=None, description="for actions that await a position or state")
    ack: int | None = Field(default=None, description="MAV_RESULT of the last COMMAND_ACK, None if none came")
    elapsed_s: float = Field(ge=0, description="wall time")
    state: Telemetry

    @property
    def ok(self) -> bool:
        return self.status == "ok"


class MissionResult(BaseModel):
    """The outcome of a mission transfer (upload, download, clear)."""

    model_config = ConfigDict(frozen=True)

    action: str
    status: TransferStatus = Field(
        description="ok; denied (the vehicle refused: see result and reason); timeout (it stopped answering); "
        "failed (bad input, or the vehicle broke the protocol)"
    )
    mission_type: MissionType
    result: str | None = Field(default=None, description="the final MISSION_ACK's MAV_MISSION_RESULT name")
    reason: str | None = Field(default=None, description="why it was refused or did not complete")
    count: int = Field(ge=0, description="items transferred (download: the items the vehicle holds)")
    items: list[MissionItem] = Field(default_factory=list, description="the items downloaded")
    resends: int = Field(default=0, ge=0, description="messages we sent again because no answer came")
    elapsed_s: float = Field(ge=0, description="wall time")
    state: Telemetry

    @property
    def ok(self) -> bool:
        return self.status == "ok"
