"""A UAV's A2A Agent Card: its three skills, the JSON-RPC interface it serves, and its state (battery, payload,
position) as a card extension, so any A2A client that reads the card learns where a UAV is and what it can do.

>>> from agentic_core.contracts.swarm import Point, UavState
>>> state = UavState(uav_id="uav-1", position=Point(north=10, east=-5, alt=30), battery_pct=76, payload=("medkit",))
>>> card = uav_card(state, "http://127.0.0.1:8001")
>>> [skill.id for skill in card.skills], card.supported_interfaces[0].url
(['survey_sector', 'verify_casualty', 'deliver_kit'], 'http://127.0.0.1:8001/a2a')
>>> state_from_card(card) == state
True
"""

from __future__ import annotations

from typing import Any

from agentic_core.swarm.a2a_extra import missing

try:
    from a2a.types.a2a_pb2 import AgentCapabilities, AgentCard, AgentExtension, AgentInterface, AgentSkill
    from google.protobuf.json_format import MessageToDict, ParseDict
    from google.protobuf.struct_pb2 import Struct
except ImportError as exc:
    raise missing(exc) from exc

from pydantic import ValidationError

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.swarm import UavState

STATE_EXTENSION = "urn:agentic-uavs:a2a:uav-state:v1"
"""The card extension whose params are the aircraft's :class:`UavState`."""
SIGNED_EXTENSION = "urn:agentic-uavs:a2a:signed-swarm-message:v1"
"""Messages carry one signed :class:`~agentic_core.contracts.swarm.SwarmMessage` as a JSON text part."""
CONTRACT_NET_EXTENSION = "urn:agentic-uavs:a2a:contract-net:v1"
"""The UAV takes part in Contract Net rounds: cfp → bid/refuse → award → accept → inform/failure."""
SWARM_MEDIA_TYPE = "application/vnd.agentic-uavs.swarm-message+json"
"""The media type of the text part that carries a signed swarm message."""
RPC_PATH = "/a2a"

SKILL_TEXT = {
    "survey_sector": ("Survey a sector", "Fly a lawnmower over a sector and report every person seen."),
    "verify_casualty": ("Verify a casualty", "Fly to a casualty another UAV reported and confirm or refute it."),
    "deliver_kit": ("Deliver a kit", "Carry a medical kit to a casualty and drop it beside them."),
}


def uav_card(state: UavState, base_url: str, *, version: str = "1.0.0") -> AgentCard:
    """The Agent Card of the UAV whose state is ``state``, served from ``base_url`` (scheme, host and port);
    ``version`` is the agent's (its skills' and extensions'), not the package's."""
    base = base_url.rstrip("/")
    skills = [
        AgentSkill(id=skill, name=name, description=text, tags=["uav", skill.split("_")[0]])
        for skill, (name, text) in SKILL_TEXT.items()
    ]
    extensions = [
        AgentExtension(uri=STATE_EXTENSION, description="battery, payload, position", params=_struct(state)),
        AgentExtension(uri=SIGNED_EXTENSION, description="HMAC-signed, nonced, timed", required=True),
        AgentExtension(uri=CONTRACT_NET_EXTENSION, description="Contract Net task allocation"),
    ]
    return AgentCard(
        name=state.uav_id,
        description=f"UAV {state.uav_id} of an agentic-uavs swarm",
        version=version,
        supported_interfaces=[AgentInterface(url=base + RPC_PATH, protocol_binding="JSONRPC", protocol_version="1.0")],
        capabilities=AgentCapabilities(streaming=False, extensions=extensions),
        default_input_modes=["text/plain", SWARM_MEDIA_TYPE],
        default_output_modes=["text/plain", "application/json", SWARM_MEDIA_TYPE],
        skills=skills,
    )


def with_state(card: AgentCard, state: UavState) -> AgentCard:
    """A copy of ``card`` whose state extension says ``state``."""
    fresh = AgentCard()
    fresh.CopyFrom(card)
    for extension in fresh.capabilities.extensions:
        if extension.uri == STATE_EXTENSION:
            extension.params.CopyFrom(_struct(state))
    return fresh


def state_from_card(card: AgentCard) -> UavState:
    """The :class:`UavState` a card advertises; :class:`InputError` when it has none or a malformed one."""
    for extension in card.capabilities.extensions:
        if extension.uri == STATE_EXTENSION:
            params: dict[str, Any] = MessageToDict(extension.params)
            try:
                return UavState.model_validate(params)
            except ValidationError as exc:
                raise InputError(f"agent card {card.name!r}: bad {STATE_EXTENSION} params: {exc}") from None
    raise InputError(f"agent card {card.name!r} has no {STATE_EXTENSION} extension")


def _struct(state: UavState) -> Struct:
    return ParseDict(state.model_dump(mode="json"), Struct())


__all__ = [
    "CONTRACT_NET_EXTENSION",
    "RPC_PATH",
    "SIGNED_EXTENSION",
    "STATE_EXTENSION",
    "SWARM_MEDIA_TYPE",
    "state_from_card",
    "uav_card",
    "with_state",
]
