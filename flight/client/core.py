"""The client's core: lifecycle, the telemetry it keeps, and waiting for the vehicle's answers from asyncio.

Why: every action is "send something, then wait until a message (or the state) says it happened", from whatever
event loop the caller runs. :class:`ClientBase` owns the :class:`~flight.client.link.Link` and the
:class:`~flight.client.telemetry.TelemetryStore`, and offers two ways to wait, both settled from the reader thread
with ``loop.call_soon_threadsafe`` (so the client is not bound to one loop: the tools executor runs async tools on
the caller's loop or on a background loop of its own, and one client serves both):

* :meth:`ClientBase._wait`: the first non-None value of a predicate over each message (and the state as it is);
* :meth:`ClientBase._listen`: every matching message, in order, as an inbox (for protocols that exchange many
  messages, such as a mission transfer, where a message arriving between two waits must not be lost).

Every wait has a wall-clock timeout, so no call hangs when the vehicle stops answering.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import threading
import time
from collections import deque
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import Any, Self

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import MAV_CMD_GET_HOME_POSITION  # MAVLink's own constant

from agentic_core.contracts.telemetry import TelemetrySample
from flight.client.link import Address, Link, VehicleConnectionError
from flight.client.telemetry import Telemetry, TelemetryState, TelemetryStore, TelemetrySubscription, sample_of

ACK_TIMEOUT_S = 1.5
ACK_ATTEMPTS = 3
LINK_SILENT_S = 15.0
"""Nothing heard from the vehicle for this long: an action waiting on it gives up (the link is gone)."""
SAMPLE_MESSAGE = "GLOBAL_POSITION_INT"
"""Each of these makes a new sample for ``on_sample`` listeners: it carries the vehicle's clock and position."""


@dataclass(eq=False, slots=True)
class _Waiter:
    loop: asyncio.AbstractEventLoop
    future: asyncio.Future[Any]
    match: Callable[[Any], Any]
    """Called with each message from the vehicle (and None for the state as it is); not None settles the wait."""


def _resolve(future: asyncio.Future[Any], value: Any) -> None:
    if not future.done():
        future.set_result(value)


class Inbox:
    """Messages matching a predicate, queued in arrival order for one coroutine (see :meth:`ClientBase._listen`)."""

    def __init__(self, match: Callable[[Any], bool]) -> None:
        self.match = match
        self.loop = asyncio.get_running_loop()
        self.queue: asyncio.Queue[Any] = asyncio.Queue()

    def offer(self, msg: Any) -> None:
        """Called by the reader thread with each message from the vehicle."""
        try:
            wanted = self.match(msg)
        except Exception:  # a predicate's bug must not stop the reader
            wanted = False
        if wanted:
            with contextlib.suppress(RuntimeError):  # the loop has closed
                self.loop.call_soon_threadsafe(self.queue.put_nowait, msg)

    async def get(self, timeout_s: float) -> Any | None:
        """The next message, or None after ``timeout_s``."""
        try:
            async with asyncio.timeout(max(0.0, timeout_s)):
                return await self.queue.get()
        except TimeoutError:
            return None


class ClientBase:
    """A MAVLink client for one vehicle: the link, the telemetry, and waiting. Make it with :meth:`connect`."""

    def __init__(
        self,
        address: str | Address,
        *,
        source_system: int = 255,
        source_component: int = 190,
        target_system: int | None = None,
        heartbeat_hz: float = 1.0,
        ack_timeout_s: float = ACK_TIMEOUT_S,
        ack_attempts: int = ACK_ATTEMPTS,
        signing_key: bytes | None = None,
    ) -> None:
        if not (1 <= source_system <= 255 and 0 <= source_component <= 255):
            raise ValueError("source system is 1..255, component 0..255")
        if not heartbeat_hz > 0:
            raise ValueError("heartbeat_hz must be positive")
        self.source_system = source_system
        self.source_component = source_component
        self.ack_timeout_s = ack_timeout_s
        """How long to wait for an answer (COMMAND_ACK, a mission message) before sending the request again."""
        self.ack_attempts = max(1, ack_attempts)
        self.link_silent_s = LINK_SILENT_S
        """Nothing heard from the vehicle for this long ends any action waiting on it (:attr:`silent_s`)."""
        self._mav = mavlink2.MAVLink(None, srcSystem=source_system, srcComponent=source_component)
        self._lock = threading.RLock()
        self._store = TelemetryStore()
        self._waiters: list[_Waiter] = []
        self._inboxes: list[Inbox] = []
        self._subscriptions: list[TelemetrySubscription] = []
        self._sample_listeners: list[Callable[[TelemetrySample], None]] = []
        self.sample_errors: deque[str] = deque(maxlen=100)
        """What ``on_sample`` callbacks raised (the reader carries on)."""
        self._link = Link(
            address,
            mav=self._mav,
            lock=self._lock,
            on_messages=self._on_messages,
            target_system=target_system,
            heartbeat_period_s=1.0 / heartbeat_hz,
            signing_key=signing_key,
        )
        self._link.start()

    # -- lifecycle --------------------------------------------------------------------------------------------

    @classmethod
    async def connect(
        cls,
        address: str | Address,
        timeout_s: float = 10.0,
        *,
        source_system: int = 255,
        source_component: int = 190,
        target_system: int | None = None,
        heartbeat_hz: float = 1.0,
        ack_timeout_s: float = ACK_TIMEOUT_S,
        ack_attempts: int = ACK_ATTEMPTS,
        signing_key: bytes | None = None,
    ) -> Self:
        """Open the link and wait for the vehicle's HEARTBEAT; :class:`VehicleConnectionError` after ``timeout_s``.
        With ``signing_key`` (32 bytes) every message is signed and only the vehicle's signed messages are taken."""
        client = cls(
            address,
            source_system=source_system,
            source_component=source_component,
            target_system=target_system,
            heartbeat_hz=heartbeat_hz,
            ack_timeout_s=ack_timeout_s,
            ack_attempts=ack_attempts,
            signing_key=signing_key,
        )
        try:
            beat = await client._wait(lambda m: m if m is not None and m.get_type() == "HEARTBEAT" else None, timeout_s)
        except BaseException:
            client.close()
            raise
        if beat is None:
            client.close()
            raise VehicleConnectionError(f"no heartbeat from a vehicle at {address!r} in {timeout_s:g} s")
        if client.home is None:  # PX4 streams HOME_POSITION slowly or only on request
            ts, tc = client._target()
            client._send(client._mav.command_long_encode(ts, tc, MAV_CMD_GET_HOME_POSITION, 0, *([0.0] * 7)))
        return client

    @property
    def target_system(self) -> int | None:
        """The vehicle's system id (learnt from its first heartbeat when not given)."""
        return self._link.target_system

    @property
    def target_component(self) -> int:
        return self._link.target_component

    @property
    def address(self) -> Address:
        """Our bound (host, port)."""
        return self._link.address

    @property
    def remote(self) -> Address | None:
        """Where the vehicle is (None until heard from, when listening)."""
        return self._link.remote

    @property
    def closed(self) -> bool:
        return self._link.closed

    @property
    def rx_messages(self) -> int:
        return self._link.rx_messages

    @property
    def rx_dropped(self) -> int:
        return self._link.rx_dropped

    def on_wire(self, hook: Callable[[bytes], None]) -> None:
        """Call ``hook`` with every MAVLink frame this client sends to or takes from its vehicle, from now on (in
        the thread that sends or reads it), e.g. a :class:`flight.tlog.TlogWriter`."""
        self._link.on_wire.append(hook)

    def link_report(self) -> dict[str, int]:
        """What the link refused: messages from elsewhere than the vehicle (``foreign``) and the signing verdicts."""
        link = self._link
        out = {"messages": link.rx_messages, "dropped": link.rx_dropped, "foreign": link.rx_foreign}
        if link.signing is not None:
            out.update(link.signing.counters.as_dict())
        return out

    def close(self) -> None:
        """Stop the reader thread and close the socket (idempotent). Pending waits end as timeouts."""
        if self._link.closed:
            return
        self._link.close()
        with self._lock:
            for sub in self._subscriptions:
                sub.end()
            self._subscriptions.clear()

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.close()

    # -- telemetry --------------------------------------------------------------------------------------------

    @property
    def telemetry(self) -> Telemetry:
        """A snapshot of the latest telemetry."""
        with self._lock:
            return self._store.snapshot(link_up=not self.closed)

    @property
    def home(self) -> tuple[float, float, float] | None:
        """(lat, lon, alt above mean sea level) of home, once HOME_POSITION has arrived."""
        with self._lock:
            return self._store.state.home

    @property
    def silent_s(self) -> float:
        """Wall seconds since the last message from the vehicle (infinite before the first, or once closed)."""
        with self._lock:
            last = self._store.state.last_rx
        return math.inf if self.closed else max(0.0, time.monotonic() - last)

    @property
    def _state(self) -> TelemetryState:
        """The live state (read it under ``self._lock``, or from a wait predicate, which runs under it)."""
        return self._store.state

    def subscribe(self) -> TelemetrySubscription:
        """Telemetry updates as an async iterator (call it on the loop that reads them)."""
        sub = TelemetrySubscription(lambda: self.telemetry, self._unsubscribe)
        with self._lock:
            self._subscriptions.append(sub)
        return sub

    def _unsubscribe(self, sub: TelemetrySubscription) -> None:
        with self._lock, contextlib.suppress(ValueError):
            self._subscriptions.remove(sub)

    def texts_since(self, mark: int) -> list[str]:
        """STATUSTEXTs received after ``mark`` (a value of :attr:`text_mark`)."""
        with self._lock:
            return self._store.texts_since(mark)

    @property
    def text_mark(self) -> int:
        with self._lock:
            return self._store.state.text_count

    def _on_messages(self, msgs: list[Any]) -> None:
        """The reader thread, under the lock: fold each message in, then settle waits and feed inboxes."""
        for msg in msgs:
            try:
                changed = self._store.fold(msg, msg.get_srcComponent() == self._link.target_component)
            except Exception:  # a malformed field must not stop the reader
                self._link.rx_dropped += 1
                continue
            self._settle_waiters(msg)
            for inbox in self._inboxes:
                inbox.offer(msg)
            if changed:
                for sub in self._subscriptions:
                    sub.notify()
            if self._sample_listeners and msg.get_type() == SAMPLE_MESSAGE:
                self._emit_sample()

    def _emit_sample(self) -> None:
        sample = sample_of(self._store.state)
        if sample is None:
            return
        for listener in list(self._sample_listeners):
            try:
                listener(sample)
            except Exception as exc:  # a subscriber's bug must not stop the reader
                self.sample_errors.append(f"{getattr(listener, '__qualname__', listener)}: {type(exc).__name__}: {exc}")

    def _settle_waiters(self, msg: Any) -> None:
        for waiter in list(self._waiters):
            try:
                value = waiter.match(msg)
            except Exception as exc:  # a predicate's bug ends its own wait, not the reader
                value = exc
            if value is None:
                continue
            self._waiters.remove(waiter)
            with contextlib.suppress(RuntimeError):  # its loop has closed: nobody waits any more
                waiter.loop.call_soon_threadsafe(_resolve, waiter.future, value)

    # -- sending and waiting ----------------------------------------------------------------------------------

    def _send(self, msg: Any) -> None:
        self._link.send(msg)

    def _target(self) -> tuple[int, int]:
        return self._link.target_system or 1, self._link.target_component

    async def _wait(self, match: Callable[[Any], Any], timeout_s: float, send: Callable[[], None] | None = None) -> Any:
        """The first non-None ``match(msg)`` (``match(None)`` is tried at once on the current state), or None
        after ``timeout_s``. An exception the predicate raised is returned, not raised. ``send`` sends the request
        whose answer is awaited: only once the waiter is in place, or a quick answer would slip past it."""
        loop = asyncio.get_running_loop()
        future: asyncio.Future[Any] = loop.create_future()
        waiter = _Waiter(loop, future, match)
        with self._lock:
            now = match(None)
            if now is not None:
                return now
            if self.closed:
                return None
            self._waiters.append(waiter)
        try:
            if send is not None:
                send()
            async with asyncio.timeout(max(0.0, timeout_s)):
                return await future
        except TimeoutError:
            return None
        finally:
            with self._lock, contextlib.suppress(ValueError):
                self._waiters.remove(waiter)

    @contextlib.asynccontextmanager
    async def _listen(self, match: Callable[[Any], bool]) -> AsyncIterator[Inbox]:
        """An :class:`Inbox` of every message from the vehicle matching ``match``, while the context lasts."""
        inbox = Inbox(match)
        with self._lock:
            self._inboxes.append(inbox)
        try:
            yield inbox
        finally:
            with self._lock, contextlib.suppress(ValueError):
                self._inboxes.remove(inbox)
