"""The mission protocol, client side: upload, download and clear plans; start a mission and follow it.

Why: a whole flight handed over at once survives a slow or lossy link better than step-by-step commands, and lets
the vehicle fly on its own. :class:`MissionClient` speaks the MAVLink mission protocol as a ground station does and
returns a :class:`~flight.client.results.MissionResult` for each transfer: ``ok``; ``denied`` with the MISSION_ACK's
MAV_MISSION_* name and the vehicle's STATUSTEXT; ``timeout`` when the vehicle stopped answering; ``failed`` for bad
input or a broken exchange.

Facts relied on (MAVLink developer guide, "Mission Protocol"; ``common.xml`` through pymavlink; PX4's
``mavlink_mission.cpp``):

* Upload: MISSION_COUNT; the vehicle requests each item with MISSION_REQUEST_INT (PX4 may ask with the legacy
  MISSION_REQUEST, which is answered with MISSION_ITEM_INT all the same, as the guide says); the vehicle ends with
  MISSION_ACK. Requests are answered as they come, repeated ones too (the vehicle resends when an item is lost).
* Download: MISSION_REQUEST_LIST → MISSION_COUNT, then MISSION_REQUEST_INT for each item → MISSION_ITEM_INT; the
  client ends with MISSION_ACK ACCEPTED.
* Clear: MISSION_CLEAR_ALL → MISSION_ACK.
* An unanswered message is sent again after the client's ACK timeout, a few times (the guide: 1.5 s, 5 retries);
  a client that gives up on an upload says so with MISSION_ACK MAV_MISSION_OPERATION_CANCELLED.
* PX4 accepts the upload of a plan that leaves the geofence, then reports it not valid (STATUSTEXT "Geofence
  violation for waypoint N", MISSION_CURRENT ``mission_state`` NO_MISSION); so after an ACCEPTED upload the client
  reads the next MISSION_CURRENT, and a plan the vehicle will not fly is ``denied`` with that reason.
* MAV_CMD_MISSION_START 300 switches to Mission and arms (PX4); MAV_CMD_DO_SET_MISSION_CURRENT 224 sets the item
  flown next.
* PX4 keeps a transfer open until 5 s pass without a message from its partner (MAVLINK_MISSION_PROTOCOL_TIMEOUT_
  DEFAULT) and meanwhile refuses another: an upload with MAV_MISSION_ERROR ("WPM: IGN MISSION_COUNT: Busy"), a
  clear with no answer but a STATUSTEXT. A download whose closing MISSION_ACK is lost leaves one open; the client
  waits it out and tries once more.
* Duplicated and late datagrams (redundant links): a mission message carries no transfer id here, so a copy of an
  earlier answer must not pass for this one. The vehicle accepts an upload only once its last item has come, asks
  only for items below the count, and in a download sends MISSION_ACK only to refuse; anything else is a stale
  copy and is ignored (MAVSDK ignores such requests too). PX4 answers a copy of our MISSION_COUNT that arrives
  mid-upload with MAV_MISSION_ERROR ("WPM: REJ. CMD: Busy") and goes on, and ends a download with
  MAV_MISSION_ERROR on a request out of order ("Req. WP was unexpected"), as a late copy of a request is: the
  client cancels such an upload and makes it again, and downloads again, once.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_MISSION_START,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_ERROR,
    MAV_MISSION_OPERATION_CANCELLED,
    MAV_RESULT_ACCEPTED,
    MAVLINK_MSG_ID_MISSION_CURRENT,
    MISSION_STATE_ACTIVE,
    MISSION_STATE_COMPLETE,
    MISSION_STATE_NO_MISSION,
    MISSION_STATE_UNKNOWN,
)

from flight.client.core import Inbox
from flight.client.mission_items import MISSION_TYPE_IDS, MissionItem, MissionType
from flight.client.operations import OperationsClient
from flight.client.results import FlightResult, MissionResult, TransferStatus, mission_result_name
from flight.client.telemetry import TelemetryState

MISSION_RETRIES = 5
"""Resends of one unanswered mission message before giving up (the MAVLink guide's maximum)."""
VALIDITY_WAIT_S = 2.0
"""After an accepted upload, how long to wait for the MISSION_CURRENT that says whether the plan may fly."""
VALIDITY_ASKS = 3
"""MISSION_CURRENTs asked for in that wait, besides the 1 Hz reports."""
CURRENT_WAIT_S = 1.5
"""How long :meth:`MissionClient.start_mission` waits for a first MISSION_CURRENT (streamed at 1 Hz)."""
TRANSFER_TIMEOUT_S = 5.5
"""How long a transfer the vehicle holds open lasts at most (PX4's mission protocol timeout, 5 s, and a margin)."""
MAX_ITEMS = 0xFFFF

UPLOAD_TRIES = 3
"""Uploads of one plan at most: a late copy of our own message can break off a try, and one more late copy (of the
cancel that ended it) the next."""


@dataclass(frozen=True)
class _Upload:
    result: MissionResult
    busy: bool = False
    """Refused before any item was asked for, as a vehicle busy with another transfer refuses."""
    interrupted: bool = False
    """Refused with MAV_MISSION_ERROR once an item was asked for, as PX4 answers a copy of our MISSION_COUNT
    delivered late ("WPM: REJ. CMD: Busy") while it goes on with the transfer, even as its last item goes out."""


class MissionClient(OperationsClient):
    """Mission transfers and Mission mode."""

    # -- transfers --------------------------------------------------------------------------------------------

    async def upload_mission(
        self, items: Sequence[MissionItem], *, mission_type: MissionType = "mission"
    ) -> MissionResult:
        """Upload ``items`` as the vehicle's ``mission_type`` plan (replacing it whole). Refused as busy at once
        (MAV_MISSION_ERROR to the MISSION_COUNT: a transfer still open on the vehicle, as after a download whose
        closing ACK was lost), it waits out the vehicle's protocol timeout and tries again. Refused with
        MAV_MISSION_ERROR once an item was asked for (a late copy of our MISSION_COUNT, or of our cancel, answered
        while the vehicle goes on), it cancels that transfer and tries again at once. :data:`UPLOAD_TRIES` in all,
        the transfer waited out once: a genuine refusal is reported as the last try's."""
        waited = False
        for _ in range(UPLOAD_TRIES - 1):
            attempt = await self._upload(items, mission_type)
            if attempt.busy and not waited:
                await self._wait_out_transfer()
                waited = True
            elif not attempt.interrupted:
                return attempt.result
        return (await self._upload(items, mission_type)).result

    async def _wait_out_transfer(self) -> None:
        """Wait until a transfer the vehicle holds open has timed out: :data:`TRANSFER_TIMEOUT_S` of the wall
        clock (PX4's, and ours when it runs), then as long of the vehicle's (PX4 SITL in lockstep)."""
        start = self._state.time_boot_s
        await asyncio.sleep(TRANSFER_TIMEOUT_S)

        def over(_msg: Any) -> Any:
            now = self._state.time_boot_s
            return True if start is None or (now is not None and now - start >= TRANSFER_TIMEOUT_S) else None

        await self._wait_on_vehicle_clock(over, TRANSFER_TIMEOUT_S, start)

    async def _upload(self, items: Sequence[MissionItem], mission_type: MissionType) -> _Upload:
        started, mark, kind = time.monotonic(), self.text_mark, MISSION_TYPE_IDS[mission_type]
        items = list(items)

        def result(
            status: TransferStatus, reason: str | None = None, ack: int | None = None, resends: int = 0
        ) -> MissionResult:
            return self._transfer_result(
                "upload_mission", mission_type, started, status, reason, ack, len(items), resends
            )

        if len(items) > MAX_ITEMS:
            return _Upload(result("failed", f"{len(items)} items: a plan holds at most {MAX_ITEMS}"))
        ts, tc = self._target()

        def wanted(msg: Any) -> bool:
            kind_of = int(getattr(msg, "mission_type", 0))
            if msg.get_type() in ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"):
                return bool(msg.target_system == self.source_system and kind_of == kind)
            return bool(msg.get_type() == "MISSION_CURRENT")

        resends, asked, sent_last = 0, False, not items

        def answers(msg: Any) -> bool:
            """A stale message (a copy delivered late, or an earlier upload's) cannot answer this upload: the
            vehicle accepts a plan only once its last item has come, and asks only for items below the count."""
            if msg.get_type() == "MISSION_CURRENT":
                return False
            if msg.get_type() == "MISSION_ACK":
                return sent_last or int(msg.type) != MAV_MISSION_ACCEPTED
            return bool(0 <= int(msg.seq) < len(items))

        async with self._listen(wanted) as inbox:
            outgoing = self._mav.mission_count_encode(ts, tc, len(items), kind)
            while True:
                msg, tries = await self._exchange(inbox, outgoing, answers)
                resends += tries
                if msg is None:
                    self._send(self._mav.mission_ack_encode(ts, tc, MAV_MISSION_OPERATION_CANCELLED, kind))
                    return _Upload(result("timeout", self._silence("upload"), resends=resends))
                if msg.get_type() == "MISSION_ACK":
                    break
                seq, asked = int(msg.seq), True
                sent_last = sent_last or seq == len(items) - 1
                frame, command, p1, p2, p3, p4, x, y, z = items[seq].int_fields()
                auto = int(items[seq].autocontinue)
                outgoing = self._mav.mission_item_int_encode(
                    ts, tc, seq, frame, command, 0, auto, p1, p2, p3, p4, x, y, z, kind
                )
            if int(msg.type) != MAV_MISSION_ACCEPTED:
                refused = result("denied", await self._refusal(mark, int(msg.type)), int(msg.type), resends)
                error = int(msg.type) == MAV_MISSION_ERROR
                if error and asked:  # the vehicle may be going on with the transfer: end it
                    self._send(self._mav.mission_ack_encode(ts, tc, MAV_MISSION_OPERATION_CANCELLED, kind))
                return _Upload(refused, busy=error and not asked, interrupted=error and asked)
            if kind == MISSION_TYPE_IDS["mission"] and items:
                current = await self._next_current(inbox, len(items))
                if current is not None and int(current.mission_state) == MISSION_STATE_NO_MISSION:
                    why = "; ".join(await self._texts_after(mark)) or "its mission check failed"
                    reason = f"the vehicle stored the mission but will not fly it: {why}"
                    return _Upload(result("denied", reason, MAV_MISSION_ACCEPTED, resends))
        return _Upload(result("ok", ack=MAV_MISSION_ACCEPTED, resends=resends))

    async def download_mission(self, *, mission_type: MissionType = "mission") -> MissionResult:
        """The vehicle's ``mission_type`` plan, in ``items``. Ended with MAV_MISSION_ERROR after its first item was
        asked for (PX4 ends a download so on a request out of order, as a copy of an earlier request delivered late
        is, and when the plan changes under it), it downloads once more."""
        first, interrupted = await self._download(mission_type)
        if not interrupted:
            return first
        return (await self._download(mission_type))[0]

    async def _download(self, mission_type: MissionType) -> tuple[MissionResult, bool]:
        started, mark, kind = time.monotonic(), self.text_mark, MISSION_TYPE_IDS[mission_type]
        ts, tc = self._target()
        got: list[MissionItem] = []
        resends = 0

        def result(status: TransferStatus, reason: str | None = None, ack: int | None = None) -> MissionResult:
            return self._transfer_result(
                "download_mission", mission_type, started, status, reason, ack, len(got), resends, got
            )

        def wanted(msg: Any) -> bool:
            types = ("MISSION_COUNT", "MISSION_ITEM_INT", "MISSION_ITEM", "MISSION_ACK")
            return bool(
                msg.get_type() in types
                and msg.target_system == self.source_system
                and int(getattr(msg, "mission_type", 0)) == kind
            )

        def refusal(msg: Any) -> bool:
            """The vehicle's MISSION_ACK in a download is a refusal; an ACCEPTED one is a copy of an upload's or a
            clear's answer delivered late (it ended the download as 'denied: MAV_MISSION_ACCEPTED')."""
            return bool(msg.get_type() == "MISSION_ACK" and int(msg.type) != MAV_MISSION_ACCEPTED)

        async with self._listen(wanted) as inbox:
            request = self._mav.mission_request_list_encode(ts, tc, kind)
            msg, resends = await self._exchange(inbox, request, lambda m: m.get_type() == "MISSION_COUNT" or refusal(m))
            if msg is None:
                return result("timeout", self._silence("download")), False
            if msg.get_type() == "MISSION_ACK":
                return result("denied", await self._refusal(mark, int(msg.type)), int(msg.type)), False
            count = int(msg.count)
            for seq in range(count):
                request = self._mav.mission_request_int_encode(ts, tc, seq, kind)

                def answers(m: Any, seq: int = seq) -> bool:
                    return refusal(m) or (m.get_type() in ("MISSION_ITEM_INT", "MISSION_ITEM") and int(m.seq) == seq)

                msg, tries = await self._exchange(inbox, request, answers)
                resends += tries
                if msg is None:
                    return result("timeout", self._silence(f"download (item {seq} of {count})")), False
                if msg.get_type() == "MISSION_ACK":
                    ack = int(msg.type)
                    return result("denied", await self._refusal(mark, ack), ack), ack == MAV_MISSION_ERROR
                try:
                    got.append(MissionItem.from_message(msg))
                except ValueError as exc:
                    self._send(self._mav.mission_ack_encode(ts, tc, MAV_MISSION_OPERATION_CANCELLED, kind))
                    return result("failed", f"item {seq} from the vehicle is not valid: {exc}"), False
            self._send(self._mav.mission_ack_encode(ts, tc, MAV_MISSION_ACCEPTED, kind))
        return result("ok"), False

    async def clear_mission(self, *, mission_type: MissionType | None = "mission") -> MissionResult:
        """Clear the vehicle's ``mission_type`` plan (None: all three). Ignored as busy (a transfer still open on
        the vehicle, which says so in a STATUSTEXT), it waits out the vehicle's protocol timeout and tries once
        more, as an upload does."""
        mark = self.text_mark
        first = await self._clear(mission_type)
        if first.status != "timeout" or not any("Busy" in text for text in self.texts_since(mark)):
            return first
        await self._wait_out_transfer()
        return await self._clear(mission_type)

    async def _clear(self, mission_type: MissionType | None) -> MissionResult:
        started, mark = time.monotonic(), self.text_mark
        kind = 255 if mission_type is None else MISSION_TYPE_IDS[mission_type]
        ts, tc = self._target()

        def wanted(msg: Any) -> bool:
            return bool(
                msg.get_type() == "MISSION_ACK"
                and msg.target_system == self.source_system
                and int(getattr(msg, "mission_type", 0)) == kind
            )

        async with self._listen(wanted) as inbox:
            msg, resends = await self._exchange(inbox, self._mav.mission_clear_all_encode(ts, tc, kind), wanted)
        label: MissionType = mission_type or "mission"
        if msg is None:
            return self._transfer_result(
                "clear_mission", label, started, "timeout", self._silence("clear"), None, 0, resends
            )
        ack = int(msg.type)
        if ack != MAV_MISSION_ACCEPTED:
            reason = await self._refusal(mark, ack)
            return self._transfer_result("clear_mission", label, started, "denied", reason, ack, 0, resends)
        return self._transfer_result("clear_mission", label, started, "ok", None, ack, 0, resends)

    async def _exchange(self, inbox: Inbox, outgoing: Any, answers: Callable[[Any], bool]) -> tuple[Any | None, int]:
        """Send ``outgoing`` and return the first message in ``inbox`` that ``answers`` it, resending after each
        ACK timeout up to :data:`MISSION_RETRIES` times; (the answer or None, the number of resends)."""
        self._send(outgoing)
        resends = 0
        deadline = time.monotonic() + self.ack_timeout_s
        while True:
            msg = await inbox.get(deadline - time.monotonic())
            if msg is not None:
                if answers(msg):
                    return msg, resends
                continue
            if resends >= MISSION_RETRIES:
                return None, resends
            resends += 1
            self._send(outgoing)
            deadline = time.monotonic() + self.ack_timeout_s

    async def _next_current(self, inbox: Inbox, count: int) -> Any | None:
        """The first MISSION_CURRENT in ``inbox`` reporting ``count`` items, within :data:`VALIDITY_WAIT_S`. One is
        asked for at once, a third and two thirds of the way (REQUEST_MESSAGE, its ACK not awaited): the 1 Hz reports
        alone, a few lost, would let a plan the vehicle will not fly pass as ``ok``, and two asks and a slow report
        were three messages, all of them lost in three."""
        start = time.monotonic()
        deadline = start + VALIDITY_WAIT_S
        asks = [start + k * VALIDITY_WAIT_S / VALIDITY_ASKS for k in range(VALIDITY_ASKS)]
        while (left := deadline - time.monotonic()) > 0:
            if asks and time.monotonic() >= asks[0]:
                asks.pop(0)
                self._ask_mission_current()
            msg = await inbox.get(min(left, max(asks[0] - time.monotonic(), 0.0)) if asks else left)
            if msg is not None and msg.get_type() == "MISSION_CURRENT" and int(msg.total) == count:
                return msg
        return None

    def _ask_mission_current(self) -> None:
        """Ask for a MISSION_CURRENT now (REQUEST_MESSAGE; its ACK is not awaited: the report is the answer)."""
        self._send_command_long(MAV_CMD_REQUEST_MESSAGE, (float(MAVLINK_MSG_ID_MISSION_CURRENT),) + (0.0,) * 6)

    async def _refusal(self, mark: int, result: int) -> str:
        name = mission_result_name(result)
        texts = await self._texts_after(mark)
        return f"{name}: {'; '.join(texts)}" if texts else name

    def _silence(self, what: str) -> str:
        tries = MISSION_RETRIES + 1
        why = f"no answer from the vehicle to the {what} after {tries} tries of {self.ack_timeout_s:g} s"
        return why if self.telemetry.connected else why + " (no telemetry from the vehicle)"

    def _transfer_result(
        self,
        action: str,
        mission_type: MissionType,
        started: float,
        status: TransferStatus,
        reason: str | None,
        ack: int | None,
        count: int,
        resends: int,
        items: list[MissionItem] | None = None,
    ) -> MissionResult:
        return MissionResult(
            action=action,
            status=status,
            mission_type=mission_type,
            result=None if ack is None else mission_result_name(ack),
            reason=reason,
            count=count,
            items=items or [],
            resends=resends,
            elapsed_s=time.monotonic() - started,
            state=self.telemetry,
        )

    # -- flying it --------------------------------------------------------------------------------------------

    async def start_mission(self, *, from_item: int | None = None, timeout_s: float = 10.0) -> FlightResult:
        """Start the uploaded mission (MAV_CMD_MISSION_START: Mission mode, arming first if needed) from its
        current item, or from ``from_item``; a finished mission starts again from item 0. Returns once the
        vehicle's first MISSION_CURRENT after the ACK reports it active (or already complete); a vehicle that
        does not report mission states, once it reports Mission mode. :meth:`wait_mission` follows it to the end."""
        op = self._begin("start_mission")
        # whether the mission is finished comes with MISSION_CURRENT (1 Hz): a fresh client asks for one and waits,
        # twice (a lost report would start a finished mission at its end: nothing flown)
        for _ in range(2):
            if self._state.mission_state != "unknown":
                break
            await self._wait(
                lambda _m: True if self._state.mission_state != "unknown" else None,
                CURRENT_WAIT_S,
                send=self._ask_mission_current,
            )
        first = from_item
        if first is None and self.telemetry.mission_state == "complete":
            first = 0
        if first is not None:
            ack = await self._command(MAV_CMD_DO_SET_MISSION_CURRENT, (float(first),))
            if not ack.accepted:
                return self._refused(op, ack)

        def evidence(msg: Any) -> bool:
            return bool(msg.get_type() in ("MISSION_CURRENT", "HEARTBEAT", "COMMAND_ACK"))

        # listen before sending: the mission may start (and a short one end) before a wait could be set up
        async with self._listen(evidence) as inbox:
            ack = await self._command(MAV_CMD_MISSION_START, (0.0, 0.0))
            if not ack.accepted:
                return self._refused(op, ack)
            started = await self._started(inbox, timeout_s)
        if not started:
            return self._result(op, "timeout", reason=f"the mission did not start in {timeout_s:g} s", ack=ack.result)
        return self._result(op, "ok", reached=True, ack=ack.result)

    async def _started(self, inbox: Inbox, timeout_s: float) -> bool:
        """Whether, after MISSION_START's ACK in ``inbox``, the vehicle says the mission runs (or ran to its end).
        Messages before the ACK describe the vehicle before it took the command, so they do not count."""
        acked = False
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            msg = await inbox.get(left)
            if msg is None:
                return False
            kind = msg.get_type()
            if kind == "COMMAND_ACK":
                acked = acked or (msg.command == MAV_CMD_MISSION_START and msg.result == MAV_RESULT_ACCEPTED)
            elif acked and kind == "MISSION_CURRENT":
                state = int(getattr(msg, "mission_state", MISSION_STATE_UNKNOWN))
                if state in (MISSION_STATE_ACTIVE, MISSION_STATE_COMPLETE):
                    return True
            elif acked and kind == "HEARTBEAT" and self._mission_mode_without_states():
                return True
        return False

    def _mission_mode_without_states(self) -> bool:
        """In Mission mode, by a vehicle that reports no mission states (the only sign a mission runs)."""
        t = self.telemetry
        return t.mission_state == "unknown" and t.mode == "mission"

    async def wait_mission(self, timeout_s: float = 3600.0) -> FlightResult:
        """Follow the mission under way until the vehicle reports it complete (MISSION_CURRENT); ``failed`` when
        it is left unfinished (another mode, a failsafe) or the plan disappears."""
        op = self._begin("wait_mission")
        seen_active = [False]

        def finished(s: TelemetryState) -> bool:
            return s.mission_state == "complete"

        def left(_msg: Any) -> Any:
            s = self._state
            if finished(s):
                return "complete"
            if s.mission_state == "active":
                seen_active[0] = True
            elif seen_active[0] and s.mission_state in ("paused", "no_mission", "not_started"):
                return f"the mission stopped unfinished at item {s.mission_seq} (mode {s.mode})"
            if op.superseded_by is not None:
                return f"superseded by {op.superseded_by}"
            return None

        outcome = await self._wait(left, timeout_s)
        if outcome == "complete":
            total = self.telemetry.mission_total
            return self._result(op, "ok", reason=f"mission complete ({total} items)", reached=True)
        if outcome is None:
            return self._result(op, "timeout", reason=f"not complete in {timeout_s:.0f} s", reached=False)
        texts = self.texts_since(op.text_mark)
        return self._result(op, "failed", reason=str(outcome) + (f" ({texts[-1]})" if texts else ""), reached=False)

    async def set_current_mission_item(self, seq: int) -> FlightResult:
        """Make item ``seq`` the one flown next (flown at once in Mission mode)."""
        op = self._begin("set_current_mission_item")
        if seq < 0 or not math.isfinite(seq):
            return self._result(op, "failed", reason=f"no item {seq}")
        ack = await self._command(MAV_CMD_DO_SET_MISSION_CURRENT, (float(seq),))
        if not ack.accepted:
            return self._refused(op, ack)
        status, reason, reached = await self._fly_wait(op, lambda s: s.mission_seq == seq, 5.0, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)
