"""Commands and parameters: COMMAND_LONG / COMMAND_INT sent until the vehicle's final COMMAND_ACK, and the
parameter protocol.

Why: the vehicle must answer every command, but a datagram can be lost, so a command without an ACK is sent again
(with ``confirmation`` incremented), and a refusal is reported with the STATUSTEXT that says why.

Facts relied on (MAVLink ``common.xml`` through pymavlink's ``dialects/v20/common.py``):

* MAV_RESULT: ACCEPTED 0, TEMPORARILY_REJECTED 1, DENIED 2, UNSUPPORTED 3, FAILED 4, IN_PROGRESS 5 (a final ACK
  follows), CANCELLED 6.
* COMMAND_INT carries param5/param6 as ``int32`` x/y and param7 as ``z`` in ``frame``.
* PX4 encodes integer parameters bytewise in PARAM_VALUE/PARAM_SET floats (MAV_PARAM_TYPE_INT32 6).
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_PARAM_TYPE_INT32,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_IN_PROGRESS,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
)

from flight.client.core import ClientBase
from flight.client.results import COMMAND_NAMES, MAV_RESULT_NAMES
from flight.px4 import mavlink_text

DENIAL_TEXT_WAIT_S = 0.3
"""After a refusal, how long to wait for the STATUSTEXT that says why if it has not come before the answer."""
PARAM_TRIES = 3
"""Sends of one parameter read or set before giving up: PARAM_VALUE is the only answer, and UDP may lose it."""


@dataclass(slots=True)
class Ack:
    """A command's final answer: the MAV_RESULT (None: no answer) and the reason for a refusal."""

    result: int | None
    reason: str | None
    resent: bool = False
    """The answer came to a copy sent again (the first's ACK, or the first, lost): a refusal may answer a vehicle
    that already did what the first copy asked."""

    @property
    def accepted(self) -> bool:
        return bool(self.result == MAV_RESULT_ACCEPTED)


class CommandClient(ClientBase):
    """Sends commands and waits for their ACKs; reads and writes parameters."""

    def _send_command_long(self, command: int, params: tuple[float, ...], confirmation: int = 0) -> None:
        ts, tc = self._target()
        self._send(self._mav.command_long_encode(ts, tc, command, confirmation, *params))

    def _send_command_int(
        self, command: int, frame: int, params: tuple[float, float, float, float], x: int, y: int, z: float
    ) -> None:
        ts, tc = self._target()
        self._send(self._mav.command_int_encode(ts, tc, frame, command, 0, 0, *params, x, y, z))

    async def command(
        self,
        command: int,
        params: tuple[float, ...] = (),
        *,
        frame: int | None = None,
        x: int = 0,
        y: int = 0,
        z: float = 0.0,
        timeout_s: float | None = None,
        attempts: int | None = None,
    ) -> tuple[int | None, str | None]:
        """Send a COMMAND_LONG (or a COMMAND_INT when ``frame`` is given) and wait for its final COMMAND_ACK,
        resending when none comes (``timeout_s``/``attempts`` default to the client's). Returns (MAV_RESULT or
        None on timeout, the reason for a refusal)."""
        ack = await self._command(command, params, frame=frame, x=x, y=y, z=z, timeout_s=timeout_s, attempts=attempts)
        return ack.result, ack.reason

    async def _command(
        self,
        command: int,
        params: tuple[float, ...],
        *,
        frame: int | None = None,
        x: int = 0,
        y: int = 0,
        z: float = 0.0,
        timeout_s: float | None = None,
        attempts: int | None = None,
    ) -> Ack:
        timeout_s = self.ack_timeout_s if timeout_s is None else timeout_s
        attempts = self.ack_attempts if attempts is None else max(1, attempts)
        full = (*params, *([0.0] * (7 - len(params))))[:7] if frame is None else (*params, 0.0, 0.0, 0.0, 0.0)[:4]
        mark = self.text_mark

        def is_ack(msg: Any) -> Any:
            if msg is None or msg.get_type() != "COMMAND_ACK" or msg.command != command:
                return None
            if msg.target_system not in (0, self.source_system):
                return None
            return msg if msg.result != MAV_RESULT_IN_PROGRESS else None

        ack = None

        def send(confirmation: int) -> None:
            if frame is None:
                self._send_command_long(command, full, confirmation=confirmation)
            else:
                p = (float(full[0]), float(full[1]), float(full[2]), float(full[3]))
                self._send_command_int(command, frame, p, x, y, z)

        resent = False
        for attempt in range(attempts):
            ack = await self._wait(is_ack, timeout_s, send=functools.partial(send, min(attempt, 255)))
            if ack is not None:
                resent = attempt > 0
                break
        name = COMMAND_NAMES.get(command, str(command))
        if ack is None:
            return Ack(None, f"no COMMAND_ACK for {name} after {attempts} attempt(s) of {timeout_s:g} s")
        result = int(ack.result)
        if result == MAV_RESULT_ACCEPTED:
            return Ack(result, None)
        texts = await self._texts_after(
            mark, wait=result in (MAV_RESULT_DENIED, MAV_RESULT_TEMPORARILY_REJECTED, MAV_RESULT_FAILED)
        )
        label = MAV_RESULT_NAMES.get(result, str(result))
        if result == MAV_RESULT_UNSUPPORTED:
            reason = f"the vehicle does not support {name} (MAV_RESULT_UNSUPPORTED)"
        else:
            said = list(dict.fromkeys(texts))  # a refusal sent again is said again
            reason = "; ".join(said) if said else f"{name}: MAV_RESULT_{label}"
        return Ack(result, reason, resent)

    async def _texts_after(self, mark: int, *, wait: bool = True) -> list[str]:
        """The STATUSTEXTs since ``mark``; if none yet and ``wait``, give one :data:`DENIAL_TEXT_WAIT_S` to come."""
        texts = self.texts_since(mark)
        if not texts and wait:
            await self._wait(
                lambda m: m if m is not None and m.get_type() == "STATUSTEXT" else None, DENIAL_TEXT_WAIT_S
            )
            texts = self.texts_since(mark)
        return texts

    # -- parameters -------------------------------------------------------------------------------------------

    async def get_param(self, name: str, timeout_s: float = 5.0) -> float | None:
        """A parameter's value (integers decoded from PX4's bytewise encoding), or None if none came."""
        ts, tc = self._target()
        request = self._mav.param_request_read_encode(ts, tc, name.encode(), -1)
        return await self._param_exchange(name, request, timeout_s)

    async def set_param(self, name: str, value: float, timeout_s: float = 5.0) -> float | None:
        """Set a parameter; returns the value the vehicle echoes (it may refuse and echo the old one), or None
        without an answer. The type is the vehicle's (read first when not yet known). An echo of another value
        (a late answer to an earlier read, or a refusal) is kept while the echo of this one may still come, until
        the try's time is up."""
        if name not in self._store.param_types and await self.get_param(name, timeout_s) is None:
            return None
        ptype = self._store.param_types[name]
        integer = ptype == MAV_PARAM_TYPE_INT32
        wire = struct.unpack("<f", struct.pack("<i", round(value)))[0] if integer else value
        wanted = float(round(value)) if integer else float(struct.unpack("<f", struct.pack("<f", value))[0])
        ts, tc = self._target()
        request = self._mav.param_set_encode(ts, tc, name.encode(), float(wire), ptype)
        return await self._param_exchange(name, request, timeout_s, wanted)

    async def _param_exchange(
        self, name: str, request: Any, timeout_s: float, wanted: float | None = None
    ) -> float | None:
        """Send ``request`` until ``name``'s PARAM_VALUE comes, :data:`PARAM_TRIES` times within ``timeout_s``:
        the parameter protocol has no other recovery for a lost datagram, and a set sent twice is the same set.
        A late answer to one try still answers the next (the match is by name). With ``wanted``, only that value
        ends a try at once; another one heard ends the tries when the try's time is up, and is returned."""
        match = self._param_match(name)
        others: list[float] = []

        def answer(msg: Any) -> Any:
            found = match(msg)
            if found is None or wanted is None or self._param_decode(found) == wanted:
                return found
            others.append(self._param_decode(found))
            return None

        for _ in range(PARAM_TRIES):
            msg = await self._wait(answer, timeout_s / PARAM_TRIES, send=functools.partial(self._send, request))
            if msg is not None:
                return self._param_decode(msg)
            if others:
                return others[-1]
        return None

    @staticmethod
    def _param_match(name: str) -> Callable[[Any], Any]:
        return lambda m: (
            m if m is not None and m.get_type() == "PARAM_VALUE" and mavlink_text(m.param_id) == name else None
        )

    @staticmethod
    def _param_decode(msg: Any) -> float:
        if msg.param_type == MAV_PARAM_TYPE_INT32:
            return float(struct.unpack("<i", struct.pack("<f", msg.param_value))[0])
        return float(msg.param_value)
