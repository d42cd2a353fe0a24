"""An agent served the way the a2a-sdk's own users serve one (its routes on Starlette, uvicorn), on 127.0.0.1."""

from __future__ import annotations

import asyncio
import socket
import threading

import uvicorn
from a2a.server.agent_execution import AgentExecutor
from a2a.server.request_handlers import DefaultRequestHandler
from a2a.server.routes import create_agent_card_routes, create_jsonrpc_routes
from a2a.server.tasks import InMemoryTaskStore
from a2a.types.a2a_pb2 import AgentCapabilities, AgentCard, AgentInterface, AgentSkill
from starlette.applications import Starlette

from tests.waiting import wait_for


class SdkAgent:
    """Serves ``executor`` under an SDK-built card named ``sdk-echo`` until the ``with`` block ends."""

    def __init__(self, executor: AgentExecutor) -> None:
        self._socket = socket.create_server(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self._socket.getsockname()[1]}"
        card = AgentCard(
            name="sdk-echo",
            description="echoes",
            version="1.0.0",
            supported_interfaces=[
                AgentInterface(url=self.url + "/rpc", protocol_binding="JSONRPC", protocol_version="1.0")
            ],
            capabilities=AgentCapabilities(streaming=False),
            default_input_modes=["text/plain"],
            default_output_modes=["text/plain"],
            skills=[AgentSkill(id="echo", name="Echo", description="echoes", tags=["echo"])],
        )
        handler = DefaultRequestHandler(executor, InMemoryTaskStore(), card)
        app = Starlette(routes=[*create_agent_card_routes(card), *create_jsonrpc_routes(handler, "/rpc")])
        self._server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="off"))
        self._thread = threading.Thread(target=lambda: asyncio.run(self._server.serve(sockets=[self._socket])))

    def __enter__(self) -> SdkAgent:
        self._thread.start()
        wait_for(lambda: self._server.started, timeout_s=10.0, what="the SDK agent to start")
        return self

    def __exit__(self, *_: object) -> None:
        self._server.should_exit = True
        self._thread.join(timeout=10.0)
        self._socket.close()
