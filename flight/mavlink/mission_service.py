"""The vehicle's mission service: the plan store, the transfer protocol and Mission mode, wired to one another and
to the link.

Why: keeps :mod:`flight.mavlink.vehicle` to the link. :class:`MissionService` owns the :class:`MissionStore`, one
:class:`MissionProtocol` per link (peer address) that fills it, and the :class:`MissionRunner` that flies it; it
applies an uploaded fence to the navigator's :class:`~flight.mavlink.geofence.Geofence`, re-checks the flight plan
whenever the plan or the fence changes, answers the mission commands, and sends MISSION_CURRENT and
MISSION_ITEM_REACHED.

Behaviour kept from PX4 (``mavlink_mission.cpp``, ``MavlinkMissionManager::send``): MISSION_CURRENT is sent once a
second and whenever it changes (ours: any of its fields, PX4 only the sequence number), and at once after the
current item is set; MISSION_ITEM_REACHED is sent when an item is reached, then the last one is repeated once a
second, ten times (for a lossy link; ours: not after the current item is set). Both are broadcast to every peer.

Transfers are per link, each with its own protocol timeouts (PX4 allows one transfer at a time on the whole
vehicle): a peer that keeps reopening an upload blocks only itself. Each upload still replaces its plan whole; the
last one completed wins. At most :data:`MAX_TRANSFER_LINKS` links keep a protocol: a new one takes the place of
the least recently active idle one, else of the least recently active one that is not ``protected`` (the
commanding ground station's).

A fence plan cannot be replaced or cleared while ``fence_locked`` gives a reason (the vehicle's: armed, and the
message not signed with its key; :mod:`flight.mavlink.guard`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
)

from flight.mavlink.commands import CommandOutcome, CommandRequest
from flight.mavlink.geofence import FenceInvalid, Geofence
from flight.mavlink.links import MAX_PEERS
from flight.mavlink.mission import MESSAGES, MissionProtocol, MissionStore
from flight.mavlink.mission_items import StoredItem
from flight.mavlink.mission_runner import MISSION_COMMANDS, MissionRunner, MissionStatus, mission_command
from flight.mavlink.navigator import Navigator

Address = tuple[str, int]

REACHED_REPEATS = 10
MAX_TRANSFER_LINKS = MAX_PEERS
REPEAT_INTERVAL_S = 1.0

__all__ = ["MESSAGES", "MISSION_COMMANDS", "MissionService"]


class MissionService:
    """Missions for one vehicle. ``send(msg, None)`` broadcasts; ``clock`` is the link clock (protocol timeouts)."""

    def __init__(
        self,
        navigator: Navigator,
        mav: mavlink2.MAVLink,
        *,
        system_id: int,
        component_id: int,
        send: Callable[[Any, Address | None], None],
        notify: Callable[[str, int], None],
        clock: Callable[[], float],
        protected: Callable[[Address], bool] = lambda address: False,
        fence_locked: Callable[[], str | None] = lambda: None,
    ) -> None:
        self.navigator = navigator
        self._mav = mav
        self._send = send
        self.store = MissionStore()
        self.runner = MissionRunner(navigator, self.store, notify)
        navigator.mission = self.runner
        self._new_protocol: Callable[[], MissionProtocol] = lambda: MissionProtocol(
            self.store,
            mav,
            system_id=system_id,
            component_id=component_id,
            send=send,
            notify=notify,
            clock=clock,
            accept=self._accept,
            changed=self._changed,
            set_current=self._set_current,
        )
        self._clock = clock
        self._protected = protected
        self._fence_locked = fence_locked
        self.protocols: dict[Address, MissionProtocol] = {}
        """One protocol per link, least recently active first."""
        self._announced: MissionStatus | None = None
        self._repeat_due = 0.0
        self._repeats_left = 0

    # -- in ---------------------------------------------------------------------------------------------------

    @property
    def busy(self) -> bool:
        """Whether a transfer is under way on any link."""
        return any(p.busy for p in self.protocols.values())

    def handle(self, msg: Any, sender: Address) -> None:
        """A mission protocol message (one of :data:`~flight.mavlink.mission.MESSAGES`), for its link's transfer."""
        self._protocol(sender).handle(msg, sender)

    def _protocol(self, sender: Address) -> MissionProtocol:
        protocols = self.protocols
        found = protocols.pop(sender, None)
        if found is None:
            if len(protocols) >= MAX_TRANSFER_LINKS:
                idle = [a for a, p in protocols.items() if not p.busy]
                others = [a for a in protocols if not self._protected(a)]
                victims = idle or others or list(protocols)
                del protocols[victims[0]]
            found = self._new_protocol()
        protocols[sender] = found  # most recently active last
        return found

    def command(self, req: CommandRequest) -> CommandOutcome:
        """MAV_CMD_MISSION_START or MAV_CMD_DO_SET_MISSION_CURRENT (see :data:`MISSION_COMMANDS`)."""
        return mission_command(self.runner, req)

    def _accept(self, mission_type: int, items: list[StoredItem]) -> str | None:
        if mission_type != MAV_MISSION_TYPE_FENCE:
            return None
        locked = self._fence_locked()
        if locked is not None:
            return locked
        home = self.navigator.sim.environment.home
        try:
            Geofence.areas_from_items(items, home.lat_deg, home.lon_deg)
        except FenceInvalid as invalid:
            return f"Fence rejected: {invalid}"
        return None

    def _changed(self, mission_type: int) -> None:
        if mission_type == MAV_MISSION_TYPE_FENCE:
            home = self.navigator.sim.environment.home
            items = list(self.store.items(MAV_MISSION_TYPE_FENCE))
            self.navigator.fence.areas = Geofence.areas_from_items(items, home.lat_deg, home.lon_deg)
            self.runner.recheck()
        elif mission_type == MAV_MISSION_TYPE_MISSION:
            self._repeats_left = 0
            self.runner.plan_changed()

    def _set_current(self, seq: int) -> None:
        self.runner.set_current(seq)

    # -- out --------------------------------------------------------------------------------------------------

    def current_fields(self) -> tuple[int, int, int, int]:
        """MISSION_CURRENT's fields as they stand (the 1 Hz stream's builder); they count as announced."""
        status = self.runner.status()
        self._announced = status
        return (status.seq, status.total, status.state, status.mode)

    def current_message(self) -> Any:
        """MISSION_CURRENT as it stands; it counts as announced."""
        return self._mav.mission_current_encode(*self.current_fields())

    def tick(self, now_s: float) -> None:
        """Once per vehicle tick, after the navigator: protocol resends and timeouts, then what changed goes out.
        ``now_s`` is simulated time (the repeats of MISSION_ITEM_REACHED are paced on it)."""
        for protocol in list(self.protocols.values()):
            protocol.tick()
        runner = self.runner
        for seq in runner.reached_events:
            self._send(self._mav.mission_item_reached_encode(seq), None)
            self._repeats_left, self._repeat_due = REACHED_REPEATS, now_s + REPEAT_INTERVAL_S
        runner.reached_events.clear()
        if runner.announce or runner.status() != self._announced:
            if runner.announce:  # the current item was set: an old "reached" is no longer news
                self._repeats_left = 0
            runner.announce = False
            self._send(self.current_message(), None)
        if self._repeats_left > 0 and now_s >= self._repeat_due and runner.reached >= 0:
            self._repeats_left -= 1
            self._repeat_due = now_s + REPEAT_INTERVAL_S
            self._send(self._mav.mission_item_reached_encode(runner.reached), None)
