"""The vehicle's receiving side: datagrams read and parsed, judged by the link guard, and each message dispatched
(heartbeats, commands, pings, parameters, offboard setpoints, missions, signing set-up).

Why: keeps :mod:`flight.mavlink.vehicle` to the link's lifecycle and its tick, as :mod:`flight.mavlink.sending` does
for the sending side. :class:`Receiver` is a mixin of :class:`~flight.mavlink.vehicle.MavlinkVehicle`. Each datagram
is parsed by a fresh pymavlink parser in robust mode, so a truncated or corrupt one cannot spoil the next; a message
we cannot act on is counted as dropped and never stops the vehicle.
"""

from __future__ import annotations

import select
import socket
from collections.abc import Callable
from typing import Any, cast

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    FAILURE_TYPE_OK,
    FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL,
    MAV_CMD_INJECT_FAILURE,
    MAV_PARAM_TYPE_INT32,
    MAV_TYPE_GCS,
)

from flight.mavlink.commands import CommandContext, CommandRequest, handle_command
from flight.mavlink.failures import FailureInjector
from flight.mavlink.guard import LinkGuard
from flight.mavlink.links import LinkTable
from flight.mavlink.mission_service import MESSAGES as MISSION_MESSAGES
from flight.mavlink.mission_service import MISSION_COMMANDS, MissionService
from flight.mavlink.navigator import CommandDenied, Navigator
from flight.mavlink.offboard import SetpointRejected, decode_global_int, decode_local_ned
from flight.mavlink.params import ParamStore, decode_value, encode_value
from flight.mavlink.telemetry import LinkStats
from flight.px4 import mavlink_text
from flight.signing import MSG_SETUP_SIGNING, Verdict
from flight.sim import Simulator

Address = tuple[str, int]

MSG_HEARTBEAT = 0
MSG_PING = 4
MSG_PARAM_REQUEST_READ = 20
MSG_PARAM_REQUEST_LIST = 21
MSG_PARAM_SET = 23
MSG_COMMAND_INT = 75
MSG_COMMAND_LONG = 76
MSG_SET_POSITION_TARGET_LOCAL_NED = 84
MSG_SET_POSITION_TARGET_GLOBAL_INT = 86
MAX_DATAGRAMS_PER_POLL = 1000
SETPOINT_WARNING_INTERVAL_S = 1.0
"""At most one STATUSTEXT per this many simulated seconds about rejected offboard setpoints."""


def _restores_link(msg: Any) -> bool:
    """Whether ``msg`` is the one command read while the MAVLink signal is failed: the injection that restores it."""
    if msg.get_msgId() not in (MSG_COMMAND_LONG, MSG_COMMAND_INT) or msg.command != MAV_CMD_INJECT_FAILURE:
        return False
    return bool(msg.param1 == FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL and msg.param2 == FAILURE_TYPE_OK)


def readiness(sock: socket.socket) -> Callable[[int], object]:
    """``check(0)``, true when ``sock`` has a datagram (or an error) to read, without waiting.

    Why: the vehicle looks for datagrams every tick and almost never finds one; asking ``poll`` is several times
    cheaper than a ``recvfrom`` that raises. Where ``select.poll`` is missing, the check says yes and ``recvfrom``
    finds out."""
    if not hasattr(select, "poll"):  # pragma: no cover - Windows
        return lambda timeout: True
    poller = select.poll()
    poller.register(sock, select.POLLIN)
    return poller.poll


class Receiver:
    """Receiving, mixed into the vehicle, which provides the attributes below."""

    sim: Simulator
    system_id: int
    component_id: int
    stats: LinkStats
    failures: FailureInjector
    guard: LinkGuard
    links: LinkTable
    params: ParamStore
    navigator: Navigator
    missions: MissionService
    last_rx_s: float | None
    _mav: mavlink2.MAVLink
    _sock: socket.socket
    _readable: Callable[[int], object]
    _link_clock: Callable[[], float]
    _in_hand: Address | None
    _setpoint_warned_s: float
    _send: Callable[..., None]
    _tap: Callable[[bytes], None]
    statustext: Callable[..., None]

    def _poll(self) -> None:
        if not self._readable(0):
            return
        for _ in range(MAX_DATAGRAMS_PER_POLL):
            try:
                data, addr = self._sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:  # e.g. an ICMP error reported on the socket: nothing to read
                continue
            self.stats.rx_datagrams += 1
            self._datagram(data, (str(addr[0]), int(addr[1])))

    def _datagram(self, data: bytes, sender: Address) -> None:
        parser = mavlink2.MAVLink(None, srcSystem=self.system_id, srcComponent=self.component_id)
        parser.robust_parsing = True
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:
            msgs = []
        valid = []
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                self.stats.rx_bad_chunks += 1
            else:
                valid.append(msg)
        if self.failures.link_off:
            valid = [m for m in valid if _restores_link(m)]
        if not valid:
            self.stats.rx_dropped += 1
            return
        armed = self.sim.armed
        accepted = [(m, v) for m in valid if (v := self.guard.judge(m, armed=armed)).accepted]
        if not accepted:
            self.stats.rx_refused += 1
            return
        first = accepted[0][0]
        signed = any(v is Verdict.SIGNED for _, v in accepted)
        self.links.heard(sender, self.sim.time_s, first.get_srcSystem(), first.get_srcComponent(), signed)
        guard = self.guard
        for msg, verdict in accepted:
            self.stats.rx_messages += 1
            self._tap(msg.get_msgbuf())
            self._in_hand, guard.in_hand_signed = sender, verdict is Verdict.SIGNED
            try:
                self._handle(msg, sender)
            except Exception:  # a message we could not act on must never stop the vehicle
                self.stats.rx_dropped += 1
            finally:
                self._in_hand, guard.in_hand_signed = None, True

    def _heartbeat(self, msg: Any, sender: Address) -> None:
        """A ground station's heartbeat (signed, when signing is on) from the commander keeps the link alive."""
        if msg.type != MAV_TYPE_GCS or (self.guard.active and not self.guard.in_hand_signed):
            return
        now = self._link_clock()
        timeout = self.params.values["COM_DL_LOSS_T"]
        if self.links.gcs_heartbeat(sender, msg.get_srcSystem(), now, timeout):
            self.last_rx_s = now

    def _for_us(self, msg: Any) -> bool:
        return msg.target_system in (0, self.system_id) and msg.target_component in (0, self.component_id)

    def _handle(self, msg: Any, sender: Address) -> None:
        msg_id = msg.get_msgId()
        if msg_id == MSG_HEARTBEAT:
            self._heartbeat(msg, sender)
        elif msg_id in (MSG_COMMAND_LONG, MSG_COMMAND_INT):
            if not self._for_us(msg):
                return
            req = CommandRequest.from_long(msg) if msg_id == MSG_COMMAND_LONG else CommandRequest.from_int(msg)
            mission = req.command in MISSION_COMMANDS
            outcome = self.missions.command(req) if mission else handle_command(cast(CommandContext, self), req)
            ack = self._mav.command_ack_encode(
                req.command, outcome.result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
            )
            self._send(ack, sender, force=req.command == MAV_CMD_INJECT_FAILURE)  # also the link's own failure
            for reply in outcome.replies:
                self._send(reply, sender)
        elif msg_id == MSG_PING:
            if msg.target_system == 0 and msg.target_component == 0:
                reply = self._mav.ping_encode(msg.time_usec, msg.seq, msg.get_srcSystem(), msg.get_srcComponent())
                self._send(reply, sender)
        elif msg_id == MSG_PARAM_REQUEST_LIST:
            if self._for_us(msg):
                for name in self.params.names:
                    self._send(self._param_value(name), sender)
        elif msg_id == MSG_PARAM_REQUEST_READ:
            if self._for_us(msg):
                found = self._param_name(msg.param_id, msg.param_index)
                if found is not None:
                    self._send(self._param_value(found), sender)
        elif msg_id == MSG_PARAM_SET and self._for_us(msg):
            self._param_set(msg, sender)
        elif msg_id in (MSG_SET_POSITION_TARGET_LOCAL_NED, MSG_SET_POSITION_TARGET_GLOBAL_INT) and self._for_us(msg):
            self._setpoint(msg, msg_id)
        elif msg_id in MISSION_MESSAGES:
            self.missions.handle(msg, sender)
        elif msg_id == MSG_SETUP_SIGNING and self._for_us(msg):
            self.guard.setup_signing(msg, armed=self.sim.armed)

    def _setpoint(self, msg: Any, msg_id: int) -> None:
        decode = decode_local_ned if msg_id == MSG_SET_POSITION_TARGET_LOCAL_NED else decode_global_int
        try:
            self.navigator.offboard_target(decode(msg, self.sim))
        except (SetpointRejected, CommandDenied) as err:
            self.navigator.offboard_heard()
            now = self.sim.time_s
            if now - self._setpoint_warned_s >= SETPOINT_WARNING_INTERVAL_S:
                self._setpoint_warned_s = now
                reason = err.reason if isinstance(err, CommandDenied) else str(err)
                self.statustext(f"Offboard setpoint ignored: {reason}")

    def _param_name(self, param_id: Any, index: int) -> str | None:
        if index >= 0:
            return self.params.names[index] if index < len(self.params) else None
        name = mavlink_text(param_id)
        return name if name in self.params else None

    def _param_value(self, name: str) -> Any:
        spec = self.params.specs[name]
        return self._mav.param_value_encode(
            name.encode(),
            encode_value(self.params[name], spec.param_type),
            spec.param_type,
            len(self.params),
            self.params.index(name),
        )

    def _param_set(self, msg: Any, sender: Address) -> None:
        name = mavlink_text(msg.param_id)
        if name not in self.params:
            self.statustext(f"Parameter {name[:16]} does not exist")
            return
        spec = self.params.specs[name]
        value = decode_value(msg.param_value, spec.param_type)
        if not self.guard.may_set_param(name, armed=self.sim.armed):
            self.statustext(f"{name}: denied while armed: needs a signed link")
        elif not self.params.set(name, value):
            shown = f"{value:.0f}" if spec.param_type == MAV_PARAM_TYPE_INT32 else f"{value:g}"
            self.statustext(f"{name}: {shown} out of range {spec.minimum:g}..{spec.maximum:g}")
        elif name.startswith("GF_"):
            self.missions.runner.recheck()  # the fence moved: is the stored mission still inside it?
        self._send(self._param_value(name), sender)


__all__ = ["MSG_HEARTBEAT", "Receiver", "readiness"]
