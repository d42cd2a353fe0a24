"""Agent Cards you can trust: a UAV's card signed as a JWS (A2A's ``signatures`` field, the a2a-sdk's signer over
the card's canonical JSON), HS256 with a key derived from the swarm's (so a card's key is never a message's), and
verified by our client before it believes anything the card says. A card changed after signing — a state, a skill,
an address — fails; so does a card signed with another swarm's key, or not signed at all.

>>> from agentic_core.contracts.swarm import Point, UavState
>>> from agentic_core.swarm.card import uav_card
>>> from agentic_core.swarm.signing import SwarmKey
>>> key = SwarmKey.generate("mina")
>>> card = sign_card(uav_card(UavState(uav_id="uav-1", position=Point(north=0, east=0), battery_pct=80),
...                           "http://127.0.0.1:8001"), key)
>>> len(card.signatures), verify_card(card, key)
(1, None)
>>> card.capabilities.extensions[0].params["battery_pct"] = 100.0
>>> try:
...     verify_card(card, key)
... except CardRejected as exc:
...     print(exc)
agent card 'uav-1': no valid signature (No valid signature found)
"""

from __future__ import annotations

import hashlib
import hmac

from agentic_core.swarm.a2a_extra import missing

try:
    from a2a.types.a2a_pb2 import AgentCard
    from a2a.utils.signing import SignatureVerificationError, create_agent_card_signer, create_signature_verifier
except ImportError as exc:
    raise missing(exc) from exc

from agentic_core.contracts.errors import RunFailure
from agentic_core.swarm.signing import SwarmKey

ALGORITHM = "HS256"


class CardRejected(RunFailure):
    """An Agent Card whose signature is missing or does not verify: nothing it says is believed."""


def card_key(key: SwarmKey) -> bytes:
    """The swarm's key for cards: HMAC-SHA256 of a fixed label under the swarm's key and name (never the message
    key itself, so a card's signature cannot be replayed as a message's or the other way round)."""
    return hmac.new(key.sign("agent-card").encode("ascii"), key.swarm.encode("utf-8"), hashlib.sha256).digest()


def sign_card(card: AgentCard, key: SwarmKey) -> AgentCard:
    """``card`` with its earlier signatures dropped and one JWS by the swarm's card key (a copy)."""
    fresh = AgentCard()
    fresh.CopyFrom(card)
    del fresh.signatures[:]
    signer = create_agent_card_signer(card_key(key), {"kid": key.swarm, "alg": ALGORITHM, "jku": None, "typ": "JOSE"})
    return signer(fresh)


def verify_card(card: AgentCard, key: SwarmKey) -> None:
    """Nothing if a signature of ``card`` verifies under the swarm's card key; else :class:`CardRejected`."""
    verifier = create_signature_verifier(lambda _kid, _jku: card_key(key), [ALGORITHM])
    try:
        verifier(card)
    except SignatureVerificationError as exc:
        raise CardRejected(f"agent card {card.name!r}: no valid signature ({exc})") from None


__all__ = ["ALGORITHM", "CardRejected", "card_key", "sign_card", "verify_card"]
