"""The mission protocol, vehicle side: the plans the vehicle stores and the upload/download state machines.

Why: ground stations and the agent's client hand the vehicle flight plans, geofences and rally points with the
MAVLink mission protocol, and read them back, over a link that can drop any message. :class:`MissionStore` keeps
the three plan types apart (MAV_MISSION_TYPE_MISSION 0, _FENCE 1, _RALLY 2); :class:`MissionProtocol` answers
MISSION_COUNT, MISSION_ITEM(_INT), MISSION_REQUEST_LIST, MISSION_REQUEST(_INT), MISSION_ACK, MISSION_CLEAR_ALL and
MISSION_SET_CURRENT, one transfer at a time, and resends its own requests until the partner answers. Whether an
item is acceptable is :mod:`flight.mavlink.mission_items`'s business; flying the mission is
:mod:`flight.mavlink.mission_runner`'s.

Behaviour kept from PX4 (``src/modules/mavlink/mavlink_mission.cpp`` and ``mavlink_mission.h`` in the PX4-Autopilot
repository, read for this; MAVLink developer guide, "Mission Protocol"):

* Messages count only when addressed to this system exactly and to its component, MAV_COMP_ID_MISSIONPLANNER 190
  or MAV_COMP_ID_ALL 0; the transfer partner is the (system, component) that started it.
* Upload: MISSION_COUNT starts it (a count above the plan's capacity is MAV_MISSION_NO_SPACE; a count of 0
  clears the plan and is ACCEPTED at once); the vehicle requests items 0..n-1 in order and resends the
  outstanding request every 0.25 s; an item out of sequence is dropped (the resend asks again); after the last
  item the new plan replaces the old at once (never a mix) and MISSION_ACK ACCEPTED goes to the partner. An item the
  vehicle cannot take ends the transfer with its MAV_MISSION_RESULT and a STATUSTEXT. A repeated MISSION_COUNT
  before item 0 came re-requests item 0; after it, MAV_MISSION_ERROR ("Busy"). Another partner's MISSION_COUNT
  during an upload gets MAV_MISSION_ERROR. The last item sent again after the ACK (the ACK was lost) gets the ACK
  again.
* Requests are MISSION_REQUEST_INT, or MISSION_REQUEST once the partner has sent a legacy MISSION_ITEM (and back
  on a MISSION_ITEM_INT). A MISSION_ACK MAV_MISSION_UNSUPPORTED from the partner during an upload switches the
  request kind; MAV_MISSION_OPERATION_CANCELLED abandons the upload.
* Download: MISSION_REQUEST_LIST is answered with MISSION_COUNT; then each MISSION_REQUEST_INT with a
  MISSION_ITEM_INT and each legacy MISSION_REQUEST with a MISSION_ITEM (PX4 answers in the kind asked). The
  expected item or the one before it (a resend) may be asked for; any other is MAV_MISSION_ERROR with a
  STATUSTEXT. The partner's MISSION_ACK ends the download. A download asked for while another transfer runs is
  ignored with an informational STATUSTEXT.
* No message from the partner for 5 s ends a transfer with the STATUSTEXT "Operation timeout".
* MISSION_CLEAR_ALL (any plan type, or MAV_MISSION_TYPE_ALL 255) is ACCEPTED; during a transfer it is ignored
  with a STATUSTEXT, as are MISSION_SET_CURRENT and stray items. Ours: a clear the ``accept`` hook refuses (for an
  empty plan) is MAV_MISSION_ERROR with its reason.

Ours, not PX4's: the vehicle starts in MISSION_REQUEST_INT (PX4's first request of a session is a legacy
MISSION_REQUEST until the partner sends a MISSION_ITEM_INT; the MAVLink guide asks for MISSION_REQUEST_INT); an
item of the wrong plan type ends the upload with MAV_MISSION_ERROR (PX4 answers MAV_MISSION_ERROR but goes on
requesting); a MISSION_COUNT for an unknown plan type is MAV_MISSION_UNSUPPORTED (PX4: NO_SPACE, its capacity
being 0); the capacity of a flight plan is :data:`CAPACITY`'s (PX4's is a build option); a finished download whose
final ACK never comes ends silently; a repeated MISSION_COUNT with a different count restarts the upload.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_COMP_ID_ALL,
    MAV_COMP_ID_MISSIONPLANNER,
    MAV_MISSION_ACCEPTED,
    MAV_MISSION_ERROR,
    MAV_MISSION_NO_SPACE,
    MAV_MISSION_OPERATION_CANCELLED,
    MAV_MISSION_TYPE_ALL,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_TYPE_RALLY,
    MAV_MISSION_UNSUPPORTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
)

from flight.mavlink.mission_items import MISSION_TYPES, ItemRejected, StoredItem, decode_item, encode_item

Address = tuple[str, int]
Partner = tuple[int, int]
"""(system id, component id) of the other end of a transfer."""

CAPACITY = {MAV_MISSION_TYPE_MISSION: 1000, MAV_MISSION_TYPE_FENCE: 64, MAV_MISSION_TYPE_RALLY: 32}
"""Items each plan type can hold (fence 64 and rally 32 as PX4's dataman; the flight plan's is ours)."""
RETRY_S = 0.25
"""Resend an unanswered item request after this long (PX4's MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT)."""
PROTOCOL_TIMEOUT_S = 5.0
"""Give a transfer up after this long without a message from the partner (MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT)."""

MSG_MISSION_ITEM = mavlink2.MAVLINK_MSG_ID_MISSION_ITEM
MSG_MISSION_REQUEST = mavlink2.MAVLINK_MSG_ID_MISSION_REQUEST
MSG_MISSION_SET_CURRENT = mavlink2.MAVLINK_MSG_ID_MISSION_SET_CURRENT
MSG_MISSION_REQUEST_LIST = mavlink2.MAVLINK_MSG_ID_MISSION_REQUEST_LIST
MSG_MISSION_COUNT = mavlink2.MAVLINK_MSG_ID_MISSION_COUNT
MSG_MISSION_CLEAR_ALL = mavlink2.MAVLINK_MSG_ID_MISSION_CLEAR_ALL
MSG_MISSION_ACK = mavlink2.MAVLINK_MSG_ID_MISSION_ACK
MSG_MISSION_REQUEST_INT = mavlink2.MAVLINK_MSG_ID_MISSION_REQUEST_INT
MSG_MISSION_ITEM_INT = mavlink2.MAVLINK_MSG_ID_MISSION_ITEM_INT
MESSAGES = frozenset(
    {
        MSG_MISSION_ITEM,
        MSG_MISSION_REQUEST,
        MSG_MISSION_SET_CURRENT,
        MSG_MISSION_REQUEST_LIST,
        MSG_MISSION_COUNT,
        MSG_MISSION_CLEAR_ALL,
        MSG_MISSION_ACK,
        MSG_MISSION_REQUEST_INT,
        MSG_MISSION_ITEM_INT,
    }
)
"""The messages :meth:`MissionProtocol.handle` takes."""


class MissionStore:
    """The vehicle's three plans, each replaced whole, and the current item of the flight plan."""

    def __init__(self) -> None:
        self._plans: dict[int, tuple[StoredItem, ...]] = dict.fromkeys(MISSION_TYPES, ())
        self.current_seq = 0
        """The flight plan's current item (the one flown next, or being flown)."""
        self.version = 0
        """Bumped on every change of any plan."""

    def items(self, mission_type: int) -> tuple[StoredItem, ...]:
        return self._plans.get(mission_type, ())

    def count(self, mission_type: int) -> int:
        return len(self.items(mission_type))

    def replace(self, mission_type: int, items: list[StoredItem], current_seq: int = 0) -> None:
        self._plans[mission_type] = tuple(items)
        if mission_type == MAV_MISSION_TYPE_MISSION:
            self.current_seq = current_seq if 0 <= current_seq < len(items) else 0
        self.version += 1

    def clear(self, mission_type: int) -> None:
        self.replace(mission_type, [])


class State(Enum):
    IDLE = "idle"
    RECEIVING = "receiving"
    """An upload: the vehicle requests items."""
    SENDING = "sending"
    """A download: the partner requests items."""


@dataclass(slots=True)
class Transfer:
    """The one transfer under way (or the last one, once idle: PX4 keeps its partner and counters)."""

    state: State = State.IDLE
    partner: Partner | None = None
    address: Address | None = None
    mission_type: int = MAV_MISSION_TYPE_MISSION
    count: int = 0
    seq: int = 0
    """Upload: the item expected next. Download: the number of items asked for so far."""
    int_mode: bool = True
    items: list[StoredItem] = field(default_factory=list)
    current: int | None = None
    last_sent: float = 0.0
    last_recv: float = 0.0


Accept = Callable[[int, list[StoredItem]], str | None]
"""Last word on an uploaded plan before it is stored: None takes it, a reason refuses it (MAV_MISSION_ERROR)."""


class MissionProtocol:
    """The vehicle's end of the mission protocol over one MAVLink encoder, replying through ``send``."""

    def __init__(
        self,
        store: MissionStore,
        mav: mavlink2.MAVLink,
        *,
        system_id: int,
        component_id: int,
        send: Callable[[Any, Address], None],
        notify: Callable[[str, int], None],
        clock: Callable[[], float],
        accept: Accept = lambda mission_type, items: None,
        changed: Callable[[int], None] = lambda mission_type: None,
        set_current: Callable[[int], None] = lambda seq: None,
    ) -> None:
        self.store = store
        self._mav = mav
        self.system_id = system_id
        self.component_id = component_id
        self._send = send
        self._notify = notify
        self._clock = clock
        self._accept = accept
        self._changed = changed
        self._set_current = set_current
        self.transfer = Transfer()
        self._last_upload: tuple[Partner, int, int] | None = None
        """(partner, plan type, count) of the last completed upload, to answer a repeated last item."""

    @property
    def busy(self) -> bool:
        return self.transfer.state is not State.IDLE

    # -- receiving --------------------------------------------------------------------------------------------

    def handle(self, msg: Any, sender: Address) -> None:
        """Act on one mission message (ignored unless addressed to this vehicle)."""
        if not self._for_us(msg):
            return
        partner = (int(msg.get_srcSystem()), int(msg.get_srcComponent()))
        kind = int(getattr(msg, "mission_type", MAV_MISSION_TYPE_MISSION))
        msg_id = msg.get_msgId()
        if msg_id == MSG_MISSION_COUNT:
            self._count(partner, sender, kind, int(msg.count))
        elif msg_id in (MSG_MISSION_ITEM, MSG_MISSION_ITEM_INT):
            self._item(msg, partner, sender, kind, msg_id == MSG_MISSION_ITEM_INT)
        elif msg_id == MSG_MISSION_REQUEST_LIST:
            self._request_list(partner, sender, kind)
        elif msg_id in (MSG_MISSION_REQUEST, MSG_MISSION_REQUEST_INT):
            self._request(partner, kind, int(msg.seq), msg_id == MSG_MISSION_REQUEST_INT)
        elif msg_id == MSG_MISSION_ACK:
            self._ack_from_partner(partner, kind, int(msg.type))
        elif msg_id == MSG_MISSION_CLEAR_ALL:
            self._clear(sender, partner, kind)
        elif msg_id == MSG_MISSION_SET_CURRENT:
            self._set_current_seq(int(msg.seq))

    def _for_us(self, msg: Any) -> bool:
        return msg.target_system == self.system_id and msg.target_component in (
            self.component_id,
            MAV_COMP_ID_MISSIONPLANNER,
            MAV_COMP_ID_ALL,
        )

    def _count(self, partner: Partner, sender: Address, kind: int, count: int) -> None:
        t = self.transfer
        if t.state is State.SENDING:
            self._critical("WPM: IGN MISSION_COUNT: Busy")
            self._ack(sender, partner, MAV_MISSION_ERROR, kind)
            return
        if t.state is State.RECEIVING:
            if partner != t.partner:
                self._ack(sender, partner, MAV_MISSION_ERROR, kind)
                return
            t.last_recv = self._clock()
            if t.seq == 0 and (kind, count) == (t.mission_type, t.count):
                self._request_item()  # our first request was lost: ask again
                return
            if t.seq > 0:
                self._critical("WPM: REJ. CMD: Busy")
                self._ack(sender, partner, MAV_MISSION_ERROR, kind)
                return
        if kind not in MISSION_TYPES:
            self._ack(sender, partner, MAV_MISSION_UNSUPPORTED, kind)
            return
        if count > CAPACITY[kind]:
            self._ack(sender, partner, MAV_MISSION_NO_SPACE, kind)
            return
        if count == 0:
            self.store.clear(kind)
            self._last_upload = None
            self.transfer = Transfer(partner=partner, address=sender, mission_type=kind)
            self._ack(sender, partner, MAV_MISSION_ACCEPTED, kind)
            self._changed(kind)
            return
        now = self._clock()
        self.transfer = Transfer(
            State.RECEIVING, partner, sender, kind, count, 0, t.int_mode, last_sent=now, last_recv=now
        )
        self._request_item()

    def _item(self, msg: Any, partner: Partner, sender: Address, kind: int, is_int: bool) -> None:
        t = self.transfer
        if partner != t.partner:
            self._critical("REJ. MIS ITEM: partner id mismatch")
            return
        seq = int(msg.seq)
        if t.state is State.IDLE:
            last = self._last_upload
            if last is not None and last[:2] == (partner, kind) and seq == last[2] - 1:
                self._ack(sender, partner, MAV_MISSION_ACCEPTED, kind)  # our ACK was lost: say it again
            else:
                self._critical("IGN MISSION_ITEM: No transfer")
                self._ack(sender, partner, MAV_MISSION_ERROR, kind)
            return
        if t.state is State.SENDING:
            self._critical("IGN MISSION_ITEM: Busy")
            self._ack(sender, partner, MAV_MISSION_ERROR, kind)
            return
        t.last_recv = self._clock()
        if kind != t.mission_type:
            self._critical(f"WPM: Unexpected mission type ({kind}, expected {t.mission_type})")
            self._abort(MAV_MISSION_ERROR)
            return
        t.int_mode = is_int
        if seq != t.seq:
            return  # out of sequence: dropped; the outstanding request is resent
        try:
            item = decode_item(msg, kind)
        except ItemRejected as rejected:
            self._critical(f"IGN MISSION_ITEM: Invalid item {seq}: {rejected.reason}")
            self._abort(rejected.result)
            return
        t.items.append(item)
        if msg.current:
            t.current = seq
        t.seq += 1
        if t.seq < t.count:
            self._request_item()
            return
        self._commit()

    def _commit(self) -> None:
        t = self.transfer
        assert t.partner is not None and t.address is not None
        why = self._accept(t.mission_type, t.items)
        if why is not None:
            self._critical(why)
            self._abort(MAV_MISSION_ERROR)
            return
        self.store.replace(t.mission_type, t.items, t.current or 0)
        t.state = State.IDLE
        self._last_upload = (t.partner, t.mission_type, t.count)
        self._ack(t.address, t.partner, MAV_MISSION_ACCEPTED, t.mission_type)
        self._changed(t.mission_type)

    def _request_list(self, partner: Partner, sender: Address, kind: int) -> None:
        t = self.transfer
        if t.state is State.SENDING and t.seq >= t.count:
            t.state = State.IDLE  # all sent; the partner's final ACK went missing
        same = t.state is State.SENDING and partner == t.partner and kind == t.mission_type
        if not (t.state is State.IDLE or same):
            self._notify("Mission download request ignored, already active", MAV_SEVERITY_INFO)
            return
        count = self.store.count(kind)
        now = self._clock()
        state = State.SENDING if count > 0 else State.IDLE
        self.transfer = Transfer(state, partner, sender, kind, count, 0, t.int_mode, last_sent=now, last_recv=now)
        self._send(self._mav.mission_count_encode(partner[0], partner[1], count, kind), sender)

    def _request(self, partner: Partner, kind: int, seq: int, as_int: bool) -> None:
        t = self.transfer
        if partner != t.partner:
            self._critical("WPM: REJ. CMD: partner id mismatch")
            return
        if t.state is State.IDLE:
            return  # PX4 ignores these silently (some OSDs send them unasked)
        if t.state is State.RECEIVING:
            self._critical("WPM: REJ. CMD: Busy")
            return
        if kind != t.mission_type:
            return
        t.last_recv = self._clock()
        if seq == t.seq and t.seq < t.count:
            t.seq += 1
        elif seq != t.seq - 1:
            self._critical("WPM: REJ. CMD: Req. WP was unexpected")
            self._abort(MAV_MISSION_ERROR)
            return
        items = self.store.items(kind)
        if seq >= len(items):  # the plan changed under the download
            self._critical("WPM: REJ. CMD: Req. WP was unexpected")
            self._abort(MAV_MISSION_ERROR)
            return
        assert t.address is not None
        current = kind == MAV_MISSION_TYPE_MISSION and seq == self.store.current_seq
        msg = encode_item(self._mav, items[seq], seq, partner, kind, current=current, as_int=as_int)
        t.last_sent = self._clock()
        self._send(msg, t.address)

    def _ack_from_partner(self, partner: Partner, kind: int, result: int) -> None:
        t = self.transfer
        if partner != t.partner:
            self._critical("REJ. WP CMD: partner id mismatch")
            return
        if t.state is State.SENDING and kind == t.mission_type:
            t.state = State.IDLE
        elif t.state is State.RECEIVING:
            t.last_recv = self._clock()
            if result == MAV_MISSION_UNSUPPORTED:  # the partner cannot answer this kind of request: try the other
                t.int_mode = not t.int_mode
                self._request_item()
            elif result == MAV_MISSION_OPERATION_CANCELLED:
                t.state = State.IDLE

    def _clear(self, sender: Address, partner: Partner, kind: int) -> None:
        if self.busy:
            self._critical("WPM: IGN CLEAR CMD: Busy")
            return
        kinds = MISSION_TYPES if kind == MAV_MISSION_TYPE_ALL else (kind,) if kind in MISSION_TYPES else ()
        if not kinds:
            self._ack(sender, partner, MAV_MISSION_UNSUPPORTED, kind)
            return
        refusal = next((why for k in kinds if (why := self._accept(k, [])) is not None), None)
        if refusal is not None:
            self._critical(refusal)
            self._ack(sender, partner, MAV_MISSION_ERROR, kind)
            return
        for k in kinds:
            self.store.clear(k)
        self._last_upload = None
        self._ack(sender, partner, MAV_MISSION_ACCEPTED, kind)
        for k in kinds:
            self._changed(k)

    def _set_current_seq(self, seq: int) -> None:
        if self.busy:
            self._critical("WPM: IGN WP CURR CMD: Busy")
        elif seq < self.store.count(MAV_MISSION_TYPE_MISSION):
            self._set_current(seq)
        else:
            self._critical("WPM: WP CURR CMD: Not in list")

    # -- time -------------------------------------------------------------------------------------------------

    def tick(self) -> None:
        """Resend an unanswered request; give up a transfer whose partner has gone quiet. Call once per tick."""
        t = self.transfer
        if t.state is State.IDLE:
            return
        now = self._clock()
        if now - t.last_recv > PROTOCOL_TIMEOUT_S:
            complete = t.state is State.SENDING and t.seq >= t.count
            t.state = State.IDLE
            if not complete:
                self._critical("Operation timeout")
            return
        if t.state is State.RECEIVING and now - t.last_sent > RETRY_S:
            self._request_item()

    # -- sending ----------------------------------------------------------------------------------------------

    def _request_item(self) -> None:
        t = self.transfer
        assert t.partner is not None and t.address is not None
        encode = self._mav.mission_request_int_encode if t.int_mode else self._mav.mission_request_encode
        t.last_sent = self._clock()
        self._send(encode(t.partner[0], t.partner[1], t.seq, t.mission_type), t.address)

    def _ack(self, to: Address, partner: Partner, result: int, kind: int) -> None:
        self._send(self._mav.mission_ack_encode(partner[0], partner[1], result, kind & 0xFF), to)

    def _abort(self, result: int) -> None:
        t = self.transfer
        t.state = State.IDLE
        if t.address is not None and t.partner is not None:
            self._ack(t.address, t.partner, result, t.mission_type)

    def _critical(self, text: str) -> None:
        self._notify(text, MAV_SEVERITY_CRITICAL)
