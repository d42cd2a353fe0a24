"""Contract Net (FIPA) over signed swarm messages, the A2A extension ``urn:agentic-uavs:a2a:contract-net:v1``.

The :class:`Manager` (the ground station, or whichever UAV leads) auctions tasks one at a time: a call for
proposals with a deadline to every live member → bids from each member's cost model (or a refusal) until the
deadline → an award to the cheapest bidder → its acceptance (or the next bidder) → later an inform or a failure.
A member that fails, reports failure or goes silent loses its tasks, which are auctioned again among the rest.
A :class:`Participant` answers on a UAV; an award it did not bid for, or from anyone but its manager, is refused
and audited (a forged, stale or replayed one never reaches it: the transport's guard refuses it first).

>>> import asyncio
>>> from agentic_core.contracts.swarm import Point, SwarmTask, UavState
>>> from agentic_core.swarm.signing import Guard, Sealer, SwarmKey
>>> key = SwarmKey.generate("mina")
>>> def member(name: str, north: float) -> LocalChannel:
...     state = UavState(uav_id=name, position=Point(north=north, east=0, alt=30), battery_pct=90)
...     return LocalChannel(Participant(Sealer(key, name), lambda: state, manager="ground"), Guard(key, name))
>>> manager = Manager(Sealer(key, "ground"), Guard(key, "ground"), {"a": member("a", 0), "b": member("b", 500)})
>>> task = SwarmTask(id="T-1", skill="survey_sector", where=Point(north=450, east=0, alt=30))
>>> asyncio.run(manager.allocate([task])).awarded
{'T-1': 'b'}
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from pydantic import ValidationError

from agentic_core.contracts.errors import AgenticUAVError
from agentic_core.contracts.swarm import Bid, SwarmMessage, SwarmTask, UavState
from agentic_core.swarm.cost import DEFAULT, CostModel, task_cost
from agentic_core.swarm.signing import Guard, Sealer

BID_WINDOW_S = 1.0
"""How long a call for proposals stays open."""


class Channel(Protocol):
    """One member as the manager reaches it: send a signed message, get its signed reply (checked) or None.

    Raises :class:`~agentic_core.contracts.errors.AgenticUAVError` when the member cannot be reached or refused."""

    async def send(self, message: SwarmMessage) -> SwarmMessage | None:
        """Deliver ``message``; the member's reply."""


class LocalChannel:
    """A member in this process: the message crosses as JSON through the member's guard, as over A2A."""

    def __init__(self, agent: Participant, guard: Guard, *, reply_guard: Guard | None = None) -> None:
        self.agent = agent
        self.guard = guard
        self.reply_guard = reply_guard
        self.alive = True

    async def send(self, message: SwarmMessage) -> SwarmMessage | None:
        """Deliver ``message`` unless the member is dead (then it never answers: the manager's deadline ends it)."""
        if not self.alive:
            await asyncio.Event().wait()
        reply = await self.agent.handle(self.guard.parse(message.model_dump_json()))
        if reply is None or self.reply_guard is None:
            return reply
        return self.reply_guard.parse(reply.model_dump_json())


class Participant:
    """A UAV's side of Contract Net: bids its cost, accepts awards it bid for, drops cancelled tasks."""

    def __init__(
        self,
        sealer: Sealer,
        state: Callable[[], UavState],
        *,
        manager: str,
        guard: Guard | None = None,
        model: CostModel = DEFAULT,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.sealer = sealer
        self.state = state
        self.manager = manager
        self.guard = guard
        self.model = model
        self._clock = clock
        self.bids: dict[str, float] = {}
        self.tasks: dict[str, SwarmTask] = {}

    async def handle(self, message: SwarmMessage) -> SwarmMessage | None:
        """The reply to a verified message: a bid or refusal, an accept or refusal, an acknowledgement, or state."""
        if message.kind == "state":
            return self._reply(message, "state", self.state().model_dump(mode="json"))
        if message.sender != self.manager:
            if self.guard is not None:
                self.guard.refuse("unauthorised", f"only {self.manager!r} may send {message.kind}", message)
            return self._reply(message, "refuse", {"reason": f"{message.sender!r} is not the manager"})
        try:
            task = SwarmTask.model_validate(message.body.get("task"))
        except ValidationError:
            return self._reply(message, "refuse", {"reason": "no valid task in the message"})
        if message.kind == "cfp":
            return self._bid(message, task)
        if message.kind == "award":
            if self.bids.get(message.conversation) is None:
                return self._reply(message, "refuse", {"task_id": task.id, "reason": "no bid of mine in this round"})
            self.tasks[task.id] = task
            return self._reply(message, "accept", {"task_id": task.id})
        if message.kind == "cancel":
            self.tasks.pop(task.id, None)
            return self._reply(message, "inform", {"task_id": task.id, "result": "cancelled"})
        return self._reply(message, "refuse", {"task_id": task.id, "reason": f"unexpected {message.kind}"})

    def report(self, task_id: str, *, done: bool, detail: str = "") -> SwarmMessage:
        """A signed ``inform`` (done) or ``failure`` of one of its tasks, for the manager."""
        if done:
            self.tasks.pop(task_id, None)
        body = {"task_id": task_id, "detail": detail}
        return self.sealer.seal("inform" if done else "failure", body, recipient=self.manager)

    def _bid(self, message: SwarmMessage, task: SwarmTask) -> SwarmMessage:
        deadline = float(message.body.get("deadline", 0.0))
        if self._clock() > deadline:
            return self._reply(message, "refuse", {"task_id": task.id, "reason": "past the deadline"})
        cost = task_cost(self.state(), task, committed=list(self.tasks.values()), model=self.model)
        if cost is None:
            return self._reply(message, "refuse", {"task_id": task.id, "reason": "cannot do it"})
        self.bids[message.conversation] = cost
        return self._reply(message, "bid", Bid(task_id=task.id, bidder=self.sealer.sender, cost=cost).model_dump())

    def _reply(self, to: SwarmMessage, kind: Any, body: Mapping[str, Any]) -> SwarmMessage:
        return self.sealer.seal(kind, body, recipient=to.sender, conversation=to.conversation)


@dataclass
class Allocation:
    """Who does what, and how it was decided: every round's bids, the members heard silent, what went unassigned."""

    awarded: dict[str, str] = field(default_factory=dict)
    costs: dict[str, float] = field(default_factory=dict)
    unassigned: list[str] = field(default_factory=list)
    rounds: list[dict[str, Any]] = field(default_factory=list)
    silent: set[str] = field(default_factory=set)
    done: set[str] = field(default_factory=set)

    def tasks_of(self, uav: str) -> list[str]:
        """The tasks awarded to ``uav`` and not yet done."""
        return [task for task, winner in self.awarded.items() if winner == uav and task not in self.done]

    @property
    def total_cost(self) -> float:
        """The sum of the winning bids, seconds."""
        return sum(self.costs.values())


class Manager:
    """Runs Contract Net rounds over ``members`` (uav id → channel); keeps the allocation and re-allocates."""

    def __init__(
        self,
        sealer: Sealer,
        guard: Guard,
        members: Mapping[str, Channel],
        *,
        bid_window_s: float = BID_WINDOW_S,
        clock: Callable[[], float] = time.time,
    ) -> None:
        self.sealer = sealer
        self.guard = guard
        self.members = dict(members)
        self.bid_window_s = bid_window_s
        self._clock = clock
        self.allocation = Allocation()
        self.tasks: dict[str, SwarmTask] = {}
        self.failed: set[str] = set()
        self._round = 0

    async def allocate(self, tasks: Iterable[SwarmTask]) -> Allocation:
        """Auction ``tasks`` one by one, in the order given, among the live members."""
        for task in tasks:
            self.tasks[task.id] = task
            await self._auction(task)
        return self.allocation

    async def _auction(self, task: SwarmTask) -> None:
        self._round += 1
        conversation = f"{task.id}#{self._round}"
        live = {uav: ch for uav, ch in self.members.items() if uav not in self.failed}
        deadline = self._clock() + self.bid_window_s
        body = {"task": task.model_dump(mode="json"), "deadline": deadline}
        replies = await self._ask_all(live, "cfp", body, conversation)
        bids = sorted(
            (b for uav, r in replies.items() if (b := _bid_of(r, uav, task)) is not None),
            key=lambda b: (b.cost, b.bidder),
        )
        silent = {uav for uav, r in replies.items() if r is None}
        self.allocation.silent |= silent
        self.allocation.rounds.append({"task": task.id, "bids": {b.bidder: b.cost for b in bids}, "silent": silent})
        for bid in bids:
            answer = await self._ask(live[bid.bidder], bid.bidder, "award", {"task": body["task"]}, conversation)
            if answer is not None and answer.kind == "accept":
                self.allocation.awarded[task.id] = bid.bidder
                self.allocation.costs[task.id] = bid.cost
                if task.id in self.allocation.unassigned:
                    self.allocation.unassigned.remove(task.id)
                return
        self.allocation.awarded.pop(task.id, None)
        self.allocation.costs.pop(task.id, None)
        if task.id not in self.allocation.unassigned:
            self.allocation.unassigned.append(task.id)

    async def _ask_all(
        self, members: Mapping[str, Channel], kind: Any, body: Mapping[str, Any], conversation: str
    ) -> dict[str, SwarmMessage | None]:
        answers = await asyncio.gather(*(self._ask(ch, uav, kind, body, conversation) for uav, ch in members.items()))
        return dict(zip(members, answers, strict=True))

    async def _ask(
        self, channel: Channel, uav: str, kind: Any, body: Mapping[str, Any], conversation: str
    ) -> SwarmMessage | None:
        """The member's reply by the deadline, or None (silent, unreachable, refused, or a reply not its own)."""
        message = self.sealer.seal(kind, body, recipient=uav, conversation=conversation)
        try:
            reply = await asyncio.wait_for(channel.send(message), timeout=self.bid_window_s)
        except (TimeoutError, AgenticUAVError):
            return None
        if reply is None or reply.sender != uav or reply.conversation != conversation:
            return None
        return reply

    async def fail(self, uav: str) -> list[str]:
        """``uav`` has failed (reported failure, crashed, or lost its link): auction its tasks again among the rest;
        the tasks re-auctioned."""
        self.failed.add(uav)
        orphaned = self.allocation.tasks_of(uav)
        for task_id in orphaned:
            del self.allocation.awarded[task_id]
            del self.allocation.costs[task_id]
            await self._auction(self.tasks[task_id])
        return orphaned

    async def heartbeat(self) -> list[str]:
        """Ask every live member with tasks for its state; one that does not answer by the deadline has failed.
        The tasks re-auctioned."""
        holders = {uav: self.members[uav] for uav in set(self.allocation.awarded.values()) if uav not in self.failed}
        replies = await self._ask_all(holders, "state", {}, f"heartbeat#{self._round}")
        moved: list[str] = []
        for uav in sorted(u for u, r in replies.items() if r is None):
            moved += await self.fail(uav)
        return moved

    async def report(self, message: SwarmMessage) -> list[str]:
        """A member's ``inform`` or ``failure`` of a task it holds (already verified): done, or the member is treated
        as failed and its tasks move. The tasks moved. A report of a task the sender does not hold changes nothing."""
        task_id = message.body.get("task_id")
        if not isinstance(task_id, str) or self.allocation.awarded.get(task_id) != message.sender:
            return []
        if message.kind == "inform":
            self.allocation.done.add(task_id)
        elif message.kind == "failure":
            return await self.fail(message.sender)
        return []


def _bid_of(reply: SwarmMessage | None, uav: str, task: SwarmTask) -> Bid | None:
    """The bid in ``reply`` if it is one, well formed, by ``uav`` itself and for ``task``; else None."""
    if reply is None or reply.kind != "bid":
        return None
    try:
        bid = Bid.model_validate(reply.body)
    except ValidationError:
        return None
    return bid if bid.bidder == uav and bid.task_id == task.id else None


__all__ = ["BID_WINDOW_S", "Allocation", "Channel", "LocalChannel", "Manager", "Participant"]
