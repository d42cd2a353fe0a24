"""Signed Agent Cards: every card a UAV serves carries a JWS over its canonical JSON (its state as of now
included), the a2a-sdk's own verifier accepts it, and our client believes no card that was changed after signing,
signed with another swarm's key, or not signed at all."""

from __future__ import annotations

import asyncio
import json
import threading
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import httpx
import pytest
from a2a.client import A2ACardResolver
from a2a.types.a2a_pb2 import AgentCard
from a2a.utils.signing import create_signature_verifier
from google.protobuf.json_format import MessageToDict

from agentic_core.contracts.swarm import Point
from agentic_core.swarm.a2a_client import A2APeer
from agentic_core.swarm.a2a_server import A2AServer
from agentic_core.swarm.card_signing import ALGORITHM, CardRejected, card_key, sign_card
from agentic_core.swarm.signing import Guard, MemoryAudit, SwarmKey
from tests.agentic_core.swarm.conftest import EchoUav, uav


@pytest.fixture
def agent(key: SwarmKey) -> EchoUav:
    return uav("uav-1", key, payload=("medkit",), battery_pct=64.0)


@pytest.fixture
def signed(agent: EchoUav, key: SwarmKey) -> Iterator[A2AServer]:
    with A2AServer(agent, Guard(key, "uav-1", audit=MemoryAudit()), card_key=key) as server:
        yield server


class _CardServer:
    """Serves one fixed card JSON at the well-known path on 127.0.0.1 (a man in the middle's card)."""

    def __init__(self, card: AgentCard) -> None:
        body = json.dumps(MessageToDict(card)).encode()

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self) -> None:
                self.send_response(200)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *_: object) -> None:
                pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()


async def _card(url: str, key: SwarmKey | None) -> AgentCard:
    async with A2APeer(url, card_key=key) as peer:
        return await peer.card()


def test_our_client_believes_a_signed_card_and_its_state_now(signed: A2AServer, agent: EchoUav, key: SwarmKey) -> None:
    assert asyncio.run(_card(signed.url, key)).signatures
    agent.current = agent.current.model_copy(update={"battery_pct": 22.0, "position": Point(north=5, east=6)})

    async def state() -> float:
        async with A2APeer(signed.url, card_key=key) as peer:
            return (await peer.state()).battery_pct

    assert asyncio.run(state()) == 22.0  # re-signed with the state of the moment


def test_the_sdks_verifier_accepts_our_signature(signed: A2AServer, key: SwarmKey) -> None:
    async def fetch() -> AgentCard:
        async with httpx.AsyncClient(timeout=5.0) as http:
            return await A2ACardResolver(http, signed.url).get_agent_card()

    card = asyncio.run(fetch())
    create_signature_verifier(lambda _kid, _jku: card_key(key), [ALGORITHM])(card)  # raises if it does not verify
    with pytest.raises(Exception, match="No valid signature"):
        create_signature_verifier(lambda _kid, _jku: b"x" * 32, [ALGORITHM])(card)


@pytest.mark.parametrize("change", ["battery", "skill", "address"])
def test_a_card_changed_after_signing_is_rejected(signed: A2AServer, key: SwarmKey, change: str) -> None:
    genuine = asyncio.run(_card(signed.url, key))
    tampered = AgentCard()
    tampered.CopyFrom(genuine)
    if change == "battery":
        tampered.capabilities.extensions[0].params["battery_pct"] = 100.0
    elif change == "skill":
        tampered.skills[0].description = "Also lands anywhere you like."
    else:
        tampered.supported_interfaces[0].url = "http://127.0.0.1:9/a2a"
    middle = _CardServer(tampered)
    try:
        with pytest.raises(CardRejected, match="no valid signature"):
            asyncio.run(_card(middle.url, key))
        assert asyncio.run(_card(middle.url, None)).name == "uav-1"  # without a key the client cannot tell
    finally:
        middle.close()


def test_a_card_of_another_swarm_or_unsigned_is_rejected(signed: A2AServer, agent: EchoUav, key: SwarmKey) -> None:
    with pytest.raises(CardRejected):
        asyncio.run(_card(signed.url, SwarmKey.generate("mina")))  # the same name, another secret
    with A2AServer(agent, Guard(key, "uav-1")) as unsigned, pytest.raises(CardRejected, match="no signatures"):
        asyncio.run(_card(unsigned.url, key))


def test_signing_again_replaces_the_old_signature(key: SwarmKey) -> None:
    from agentic_core.swarm.card import uav_card

    card = uav_card(uav("uav-9", key).current, "http://127.0.0.1:1")
    twice = sign_card(sign_card(card, key), key)
    assert len(twice.signatures) == 1 and not card.signatures
