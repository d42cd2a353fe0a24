"""The console's web application (Starlette): the page and its files, the runs of ``--runs-dir`` to replay, and
with a live run its stream (server-sent events) and its controls.

Reads of the API need the token (``Authorization: Bearer``, or ``?token=`` for the event stream); every change
(a control command, an answer, resuming or forking a run) is a POST with the token in its header and the
console's own Origin (:mod:`~agentic_core.console.access`), and a body of at most 64 KiB of JSON
(:mod:`~agentic_core.console.bodies`). The page itself loads nothing from anywhere else:
a Content-Security-Policy of ``'self'`` holds the browser to that.
"""

from __future__ import annotations

import inspect
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path
from typing import Any, Protocol

from flight.sim.scene_model import Scene

from ..contracts.errors import InputError
from ..contracts.extras import require
from .access import Guard
from .basemap import GroundPictures
from .bodies import BodyRefused, parse_object, read_bounded
from .campaigns import list_campaigns
from .feed import LiveFeed
from .launch import Launcher, RunBusy
from .runs import list_runs, replay, run_scene
from .swarms import listing, replay_swarm

STATIC = Path(str(files("agentic_core.console") / "static"))
COMMANDS = ("pause", "resume", "hold", "rtl", "land", "abort")
MAX_EDITS = 20
"""Edited arguments an approval may carry at most (a step has a handful)."""
CSP = (
    "default-src 'self'; img-src 'self' data:; style-src 'self' 'unsafe-inline'; script-src 'self'; "
    "connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'"
)


Edits = dict[str, Any]


class Steering(Protocol):
    """What the console steers a live run through: the run's control port."""

    def pause(self, *, by: str = ...) -> None: ...
    def resume(self, *, by: str = ...) -> None: ...
    def hold(self, *, by: str = ...) -> None: ...
    def rtl(self, *, by: str = ...) -> None: ...
    def land(self, *, by: str = ...) -> None: ...
    def abort(self, reason: str | None = ..., *, by: str = ...) -> None: ...
    def approve(
        self, question_id: str | None = ..., reason: str | None = ..., *, by: str = ..., args: Edits | None = ...
    ) -> bool: ...
    def decline(self, question_id: str | None = ..., reason: str | None = ..., *, by: str = ...) -> bool: ...


@dataclass
class Live:
    """A live run as the console sees it: its feed and its control port."""

    feed: LiveFeed
    control: Steering
    scene: Scene | None = None


def build_app(
    runs_dir: Path,
    guard: Guard,
    live: Live | None = None,
    launcher: Launcher | None = None,
    campaigns_dir: Path | None = None,
) -> Any:
    """The ASGI application (needs the ``console`` extra); ``launcher`` resumes and forks runs; the campaigns
    shown are those under ``campaigns_dir`` (by default ``runs_dir``)."""
    applications = require("starlette.applications", "console")
    responses = require("starlette.responses", "console")
    routing = require("starlette.routing", "console")
    staticfiles = require("starlette.staticfiles", "console")
    sse = require("sse_starlette.sse", "console")
    concurrency = require("starlette.concurrency", "console")
    JSONResponse = responses.JSONResponse
    pictures = GroundPictures()

    def refused(why: str) -> Any:
        return JSONResponse({"error": why}, status_code=403)

    def reading(handler: Callable[[Any], Any]) -> Callable[[Any], Any]:
        async def checked(request: Any) -> Any:
            why = guard.refuse_read(request.headers, request.query_params)
            return refused(why) if why else await handler(request)

        return checked

    def changing(handler: Callable[[Any, Any], Any], *, steers: bool = True) -> Callable[[Any], Any]:
        async def checked(request: Any) -> Any:
            why = guard.refuse_change(request.headers)
            if why:
                return refused(why)
            try:
                body = parse_object(await read_bounded(request.headers, request.stream()))
            except BodyRefused as exc:
                return JSONResponse({"error": str(exc)}, status_code=exc.status)
            if steers and live is None:
                return JSONResponse({"error": "no live run to steer: this console replays runs"}, status_code=409)
            answer = handler(request, body)
            return await answer if inspect.isawaitable(answer) else answer

        return checked

    async def index(request: Any) -> Any:
        return responses.FileResponse(STATIC / "index.html", headers={"Cache-Control": "no-store"})

    async def runs(request: Any) -> Any:
        return JSONResponse({"runs": listing(runs_dir, list_runs(runs_dir)), "live": live is not None})

    async def campaigns(request: Any) -> Any:
        return JSONResponse({"campaigns": list_campaigns(campaigns_dir or runs_dir)})

    def found(read: Callable[[Path, str], Any], runs_dir: Path, ident: str) -> Any:
        """``read``'s answer for one run or swarm, or 404 saying why there is none."""
        try:
            return JSONResponse(read(runs_dir, ident))
        except InputError as exc:
            return JSONResponse({"error": str(exc)}, status_code=404)

    async def one_run(request: Any) -> Any:
        return found(replay, runs_dir, request.path_params["run_id"])

    async def ground(request: Any) -> Any:
        run_id = request.path_params["run_id"]
        try:
            is_live = live is not None and live.scene is not None and live.feed.static.get("run_id") == run_id
            scene = live.scene if is_live and live is not None else run_scene(runs_dir, run_id)
        except InputError as exc:
            return JSONResponse({"error": str(exc)}, status_code=404)
        if scene is None:
            return JSONResponse({"error": f"run {run_id!r}: no scene to draw"}, status_code=404)
        png = await concurrency.run_in_threadpool(pictures.png, scene)
        return responses.Response(png, media_type="image/png", headers={"Cache-Control": "private, max-age=3600"})

    async def one_swarm(request: Any) -> Any:
        return found(replay_swarm, runs_dir, request.path_params["swarm_id"])

    async def stream(request: Any) -> Any:
        if live is None:
            return JSONResponse({"error": "no live run"}, status_code=404)
        import asyncio

        page, first = live.feed.connect(asyncio.get_running_loop())

        async def messages() -> AsyncIterator[dict[str, str]]:
            try:
                yield {"data": first}
                while True:
                    text = await page.queue.get()
                    if text is None:
                        yield {"event": "end", "data": "{}"}
                        return
                    yield {"data": text}
            finally:
                live.feed.disconnect(page)

        return sse.EventSourceResponse(messages(), ping=10, headers={"Cache-Control": "no-store"})

    def command(request: Any, body: dict[str, Any]) -> Any:
        name = request.path_params["command"]
        if name not in COMMANDS or live is None:
            return JSONResponse({"error": f"no command {name!r} (one of {', '.join(COMMANDS)})"}, status_code=404)
        reason = body.get("reason")
        if name == "abort":
            live.control.abort(str(reason) if reason else None, by="console")
        else:
            getattr(live.control, name)(by="console")
        return JSONResponse({"ok": True, "command": name})

    def answer(request: Any, body: dict[str, Any]) -> Any:
        assert live is not None
        approve = body.get("approve")
        if not isinstance(approve, bool):
            return JSONResponse({"error": "say approve: true or false"}, status_code=400)
        reason = body.get("reason")
        reason = str(reason)[:500] if reason else None
        qid = request.path_params["question_id"]
        edits = body.get("args")
        if edits is not None and (not approve or not isinstance(edits, dict) or not edits or len(edits) > MAX_EDITS):
            problem = f"args: an object of up to {MAX_EDITS} edited arguments, with an approval"
            return JSONResponse({"error": problem}, status_code=400)
        asked = live.feed.asked(qid)
        own = sorted((asked or {}).get("args") or {})
        unknown = sorted(set(edits or {}) - set(own)) if isinstance((asked or {}).get("args"), dict) else []
        if unknown:  # the step would refuse them once answered: say so now, the question still waiting
            problem = f"args: {', '.join(unknown)}: not an argument of this step ({', '.join(own)})"
            return JSONResponse({"error": problem}, status_code=400)
        if approve:
            done = live.control.approve(qid, reason, by="console", args=edits)
        else:
            done = live.control.decline(qid, reason, by="console")
        if not done:
            return JSONResponse({"error": f"no question {qid!r} is waiting"}, status_code=404)
        return JSONResponse({"ok": True})

    async def relaunch(request: Any, body: dict[str, Any]) -> Any:
        """Resume or fork a run (files copied, a process started): off the event loop, so streams flow on."""
        return await concurrency.run_in_threadpool(start_run, request, body)

    def start_run(request: Any, body: dict[str, Any]) -> Any:
        run_id, action = request.path_params["run_id"], request.url.path.rsplit("/", 1)[-1]
        checkpoint = body.get("checkpoint")
        if launcher is None:
            return JSONResponse({"error": "this console starts no runs"}, status_code=404)
        if action == "fork" and not isinstance(checkpoint, str):
            return JSONResponse({"error": "fork: say which checkpoint (a string)"}, status_code=400)
        try:
            started = launcher.resume(run_id) if action == "resume" else launcher.fork(run_id, str(checkpoint))
        except RunBusy as exc:
            return JSONResponse({"error": str(exc)}, status_code=409)
        except InputError as exc:
            return JSONResponse({"error": str(exc)}, status_code=404)
        return JSONResponse({"ok": True, "run_id": started})

    async def security_headers(scope: Any, receive: Any, send: Any) -> None:
        async def send_with(message: Any) -> None:
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", []))
                headers += [(b"content-security-policy", CSP.encode()), (b"x-content-type-options", b"nosniff"),
                            (b"referrer-policy", b"no-referrer")]  # fmt: skip
                message = {**message, "headers": headers}
            await send(message)

        await app(scope, receive, send_with)

    route, mount = routing.Route, routing.Mount
    app = applications.Starlette(
        routes=[
            route("/", index),
            route("/api/runs", reading(runs)),
            route("/api/campaigns", reading(campaigns)),
            route("/api/runs/{run_id}", reading(one_run)),
            route("/api/runs/{run_id}/ground.png", reading(ground)),
            route("/api/swarms/{swarm_id}", reading(one_swarm)),
            route("/api/live/stream", reading(stream)),
            route("/api/control/{command}", changing(command), methods=["POST"]),
            route("/api/questions/{question_id}", changing(answer), methods=["POST"]),
            route("/api/runs/{run_id}/resume", changing(relaunch, steers=False), methods=["POST"]),
            route("/api/runs/{run_id}/fork", changing(relaunch, steers=False), methods=["POST"]),
            mount("/static", staticfiles.StaticFiles(directory=STATIC)),
        ]
    )
    return security_headers


__all__ = ["COMMANDS", "Live", "Steering", "build_app"]
