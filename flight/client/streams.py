"""Telemetry for a consumer outside asyncio: the vehicle's stream rates on this link, and a callback per sample.

Why: the agent's camera wants the vehicle's pose at 30 Hz, and perception runs on its own thread. PX4 (and the
simulated vehicle) stream ATTITUDE, GLOBAL_POSITION_INT and LOCAL_POSITION_NED at a few hertz by default;
:meth:`StreamsClient.set_stream_rates` asks for more with MAV_CMD_SET_MESSAGE_INTERVAL, and
:meth:`StreamsClient.on_sample` hands every new :class:`~agentic_core.contracts.telemetry.TelemetrySample` to a
callback.

Facts relied on (MAVLink ``common.xml`` through pymavlink's ``dialects/v20/common.py``): MAV_CMD_SET_MESSAGE_INTERVAL
511, param1 the message id, param2 the interval in µs (-1 stops the stream, 0 restores the default); PX4 keeps one
rate table per link, so the rates change for this client's link only (so does the simulated vehicle).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Mapping

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import MAV_CMD_SET_MESSAGE_INTERVAL, MAV_RESULT_ACCEPTED

from agentic_core.contracts.telemetry import TelemetrySample
from flight.client.commands import CommandClient

CAMERA_STREAMS = ("ATTITUDE", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED")
"""The messages a :class:`TelemetrySample` is made of that change quickly: what a camera needs fast."""


def message_id(message: int | str) -> int:
    """A MAVLink message id from its id or its name (``"ATTITUDE"`` → 30); ValueError for an unknown one.

    >>> message_id("GLOBAL_POSITION_INT"), message_id(32)
    (33, 32)
    """
    if isinstance(message, str):
        found = getattr(mavlink2, f"MAVLINK_MSG_ID_{message.strip().upper()}", None)
        if not isinstance(found, int):
            raise ValueError(f"unknown MAVLink message {message!r}")
        return found
    if message not in mavlink2.mavlink_map:
        raise ValueError(f"unknown MAVLink message id {message!r}")
    return int(message)


def interval_us(rate_hz: float | None) -> float:
    """SET_MESSAGE_INTERVAL's param2 for a rate: µs between messages, -1 for 0 Hz (off), 0 for None (default)."""
    if rate_hz is None:
        return 0.0
    if not (math.isfinite(rate_hz) and rate_hz >= 0):
        raise ValueError(f"a stream rate is a finite number of hertz >= 0 (or None for the default), not {rate_hz}")
    return -1.0 if rate_hz == 0 else 1e6 / rate_hz


class StreamsClient(CommandClient):
    """Stream rates and per-sample callbacks."""

    async def set_stream_rates(
        self, rates: Mapping[int | str, float | None], *, timeout_s: float | None = None
    ) -> dict[int, bool]:
        """Ask the vehicle to send each message (id or name) at its rate in Hz (0: off, None: its default); for
        each message id, whether the vehicle accepted. Bad ids or rates raise ValueError before anything is sent.

        ``await client.set_stream_rates({name: 30.0 for name in CAMERA_STREAMS})`` gives a camera its poses."""
        wanted = {message_id(msg): interval_us(hz) for msg, hz in rates.items()}
        accepted: dict[int, bool] = {}
        for msg_id, interval in wanted.items():
            ack = await self._command(MAV_CMD_SET_MESSAGE_INTERVAL, (float(msg_id), interval), timeout_s=timeout_s)
            accepted[msg_id] = ack.result == MAV_RESULT_ACCEPTED
        return accepted

    def on_sample(self, callback: Callable[[TelemetrySample], None]) -> Callable[[], None]:
        """Call ``callback`` with a new :class:`TelemetrySample` each time a GLOBAL_POSITION_INT arrives (once a
        LOCAL_POSITION_NED has been heard too), with the latest attitude, local position, mode and battery heard.
        Returns a function that ends the subscription (idempotent).

        The callback runs in the client's reader thread, holding the client's lock: keep it short (hand the sample
        to a queue), since the reader reads nothing else meanwhile. It may read the client's telemetry, not await
        its actions. What it raises is recorded in ``sample_errors``; the reader carries on."""
        with self._lock:
            self._sample_listeners.append(callback)

        def cancel() -> None:
            with self._lock, contextlib.suppress(ValueError):
                self._sample_listeners.remove(callback)

        return cancel
