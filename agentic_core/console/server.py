"""Serving the console: :class:`ConsoleServer` runs uvicorn on a thread of its own (its own event loop), so a
run flies in the caller's thread while pages watch it; :func:`watch` hangs a live run's bus, telemetry, World
Model and questions on a :class:`~agentic_core.console.feed.LiveFeed`.

>>> check_bind("127.0.0.1", None)  # the default address needs no token given: one is made per server
"""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..contracts.errors import InputError
from ..contracts.extras import require
from .access import Guard, check_bind, is_loopback, make_token
from .app import Live, build_app
from .feed import LiveFeed
from .launch import Launcher
from .views import mission_view, scene_view, world_view

if TYPE_CHECKING:
    from ..run.runner import MissionRun

WORLD_HZ = 2.0
"""World Models sent to the pages per second of wall time (the tracker runs at the camera's rate)."""


class ConsoleServer:
    """The console on ``host:port`` (port 0: any free one), on a background thread; :attr:`url` opens it."""

    def __init__(self, runs_dir: Path, *, host: str = "127.0.0.1", port: int = 8765, token: str | None = None,
                 live: Live | None = None, campaigns_dir: Path | None = None) -> None:  # fmt: skip
        check_bind(host, token)
        self.token = token or make_token()
        self.host = host
        self.live = live
        uvicorn = require("uvicorn", "console")
        self.launcher = Launcher(runs_dir)
        guard = Guard(self.token, loopback_only=is_loopback(host))
        app = build_app(runs_dir, guard, live, self.launcher, campaigns_dir)
        config = uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="off",
                                timeout_graceful_shutdown=2, access_log=False)  # fmt: skip
        self._server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None
        self.port = port

    def start(self, timeout_s: float = 10.0) -> ConsoleServer:
        """Bind here (:class:`InputError` when the address cannot be had), then serve on the thread."""
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((self.host, self.port))
        except OSError as exc:
            sock.close()
            raise InputError(f"console: cannot listen on {self.host}:{self.port}: {exc.strerror or exc}") from None
        self.port = int(sock.getsockname()[1])
        self._thread = threading.Thread(target=self._server.run, kwargs={"sockets": [sock]}, name="console-server",
                                        daemon=True)  # fmt: skip
        self._thread.start()
        deadline = time.monotonic() + timeout_s
        while not self._server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise InputError(f"console: the server on {self.host}:{self.port} did not start")
            time.sleep(0.01)
        return self

    @property
    def url(self) -> str:
        """The page's address with its token in the fragment (never sent to the server, kept out of its logs)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/#token={self.token}"

    @property
    def serving(self) -> bool:
        """True while the server's thread runs."""
        return self._thread is not None and self._thread.is_alive()

    def stop(self) -> None:
        """End every page's stream, stop the runs it resumed or forked, and stop serving."""
        if self.live is not None:
            self.live.feed.close()
        self._server.should_exit = True
        if self._thread is not None and self._thread.is_alive():
            self._thread.join(timeout=5.0)
        self.launcher.stop()

    def __enter__(self) -> ConsoleServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def watch(run: MissionRun, feed: LiveFeed | None = None) -> Live:
    """A live run's :class:`Live`: its events, telemetry, World Model (at :data:`WORLD_HZ`) and questions fed to
    ``feed`` (a new one by default), its control port to steer it."""
    feed = feed or LiveFeed()
    scene = run.scene
    home = (scene.home.lat_deg, scene.home.lon_deg) if scene is not None else None
    feed.static = {"run_id": run.run_id, "live": True, "mission": mission_view(run.plan, home),
                   **({"scene": scene_view(scene)} if scene is not None else {})}  # fmt: skip
    run.bus.subscribe(lambda event: feed.event(event.model_dump(mode="json")))
    run.backend.on_sample(lambda sample: feed.telemetry(sample.model_dump(mode="json")))
    run.control.on_question(lambda question: feed.question(question.id, question.request))
    if run.loop is not None:
        last = [0.0]

        def world(model: Any) -> None:
            now = time.monotonic()
            if now - last[0] >= 1.0 / WORLD_HZ:
                last[0] = now
                feed.world(world_view(model.model_dump(mode="json", by_alias=True)))

        run.loop.on_world.append(world)
    return Live(feed, run.control, scene)


class ConsoleOperator:
    """The operator when the console answers approvals: it answers nothing itself and returns once the question
    is answered on the control port (by a click, a timeout or a stop), so that no terminal reads a stdin that a
    person at the browser never types into."""

    def __init__(self, timeout_s: float) -> None:
        self.timeout_s = timeout_s
        self.control: Any = None

    def __call__(self, request: dict[str, Any]) -> Any:
        from ..agent.control import OperatorAnswer

        deadline = time.monotonic() + self.timeout_s + 1.0
        while time.monotonic() < deadline:
            control = self.control
            if control is not None and not any(q.request == request for q in control.pending()):
                break
            if control is not None:
                control.wait_for_change(0.5)
            else:
                time.sleep(0.05)
        return OperatorAnswer(False, None, "left to the console")  # the port has its answer already: unused


__all__ = ["WORLD_HZ", "ConsoleOperator", "ConsoleServer", "watch"]
