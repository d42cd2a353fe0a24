"""The swarm's ground side during a run: Contract Net over signed messages allocates the sectors, then the
casualty work (verify, deliver) as it comes; each UAV's agent asks it for its next task through the ``swarm.*``
tools (:mod:`agentic_core.swarm.fleet_tools`). It watches the members: one whose vehicle has died loses its tasks, which
are auctioned again among the rest. Everything it decides goes to ``swarm.jsonl``; refused messages to the audit.

The manager runs on its own asyncio loop (thread ``swarm-manager``); the tools call it from the UAVs' tool threads
and wait for the answer (:meth:`SwarmCoordinator.call`). Every message crosses as JSON through the receiver's
:class:`~agentic_core.swarm.signing.Guard`: with ``a2a=True`` (a swarm run) over HTTP, each UAV an A2A agent on
127.0.0.1 with its signed Agent Card (:class:`~agentic_core.swarm.a2a_channel.A2AChannel`); else in-process.

>>> from agentic_core.swarm.signing import SwarmKey
>>> from agentic_core.contracts.swarm import Point, UavState
>>> from agentic_core.swarm.sectors import Sector
>>> state = lambda: UavState(uav_id="uav-1", position=Point(north=0, east=0, alt=30), battery_pct=90)
>>> sector = Sector("S1", ((0.0, 0.0), (0.001, 0.0), (0.001, 0.001)), Point(north=50, east=50))
>>> from agentic_core.swarm.coordinator import SwarmCoordinator
>>> swarm = SwarmCoordinator(SwarmKey.generate("doc"), [Member("uav-1", state, layer_m=30.0)], [sector])
>>> swarm.allocate_sectors()
{'S1': 'uav-1'}
>>> swarm.next_task("uav-1")["skill"]
'survey_sector'
>>> swarm.close()
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable, Coroutine, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

from agentic_core.contracts.errors import AgenticUAVError
from agentic_core.contracts.swarm import Point, SwarmMessage, SwarmTask, UavState
from agentic_core.contracts.swarm_plan import Heartbeat, Verification
from agentic_core.contracts.world_model import WorldModel
from agentic_core.swarm.consensus import ConsensusAgent, agree
from agentic_core.swarm.contract_net import LocalChannel, Manager, Participant
from agentic_core.swarm.deconflict import Airspace
from agentic_core.swarm.fusion import fuse
from agentic_core.swarm.heartbeat import Heartbeats
from agentic_core.swarm.legs import LegBook
from agentic_core.swarm.operator_verify import Ask, ask_operator
from agentic_core.swarm.sectors import Sector
from agentic_core.swarm.signing import Audit, Guard, MemoryAudit, Sealer, SwarmKey

if TYPE_CHECKING:
    from agentic_core.swarm.a2a_channel import A2AChannel
    from agentic_core.swarm.a2a_client import A2APeer

T = TypeVar("T")
GROUND = "ground"
SAME_OBJECT_M = 10.0
"""A claim this near an earlier one of the same class is the same casualty."""


@dataclass
class Member:
    """One UAV as the coordinator sees it: its state and World Model (read live), whether it lives, its layer."""

    uav: str
    state: Callable[[], UavState]
    layer_m: float
    world: Callable[[], WorldModel | None] = lambda: None
    alive: Callable[[], bool] = lambda: True
    park: tuple[float, float] = (0.0, 0.0)
    """Where it waits for work (latitude, longitude): over its own pad, clear of every other UAV's."""
    ask: Ask | None = None
    """Its operator, for a mission whose casualties the operator verifies (:mod:`.operator_verify`)."""


class FinderRefuses(Participant):
    """A participant that does not bid to verify its own find (a verification is another UAV's eyes), and, without
    the ground, hears the other UAVs' consensus bids (``consensus``: its side of the consensus under way)."""

    consensus: ConsensusAgent | None = None

    async def handle(self, message: SwarmMessage) -> SwarmMessage | None:
        if message.kind == "bid" and message.conversation == "consensus":
            changed = self.consensus.take(message) if self.consensus is not None else False
            return self.sealer.seal("inform", {"changed": changed}, recipient=message.sender, conversation="consensus")
        task = message.body.get("task")
        parts = str(task.get("id", "")).split(":") if isinstance(task, dict) else []
        if message.kind == "cfp" and parts[:2] == ["verify_casualty", self.sealer.sender]:
            return self.sealer.seal(
                "refuse", {"reason": "my own find"}, recipient=message.sender, conversation=message.conversation
            )
        return await super().handle(message)


@dataclass
class Casualty:
    """A casualty the fleet responds to: who found it, where, who verified it, who delivers."""

    id: str
    finder: str
    object_id: str
    where: Point
    lat: float
    lon: float
    verified_by: list[str] = field(default_factory=list)
    verified: bool = False
    delivery: str | None = None
    delivered: bool = False


class SwarmCoordinator:
    """See the module docstring. ``log`` receives every decision as a dict (a line of ``swarm.jsonl``)."""

    def __init__(
        self,
        key: SwarmKey,
        members: Iterable[Member],
        sectors: Iterable[Sector],
        *,
        rounds: int = 1,
        verify_k: int = 2,
        verification: Verification | None = None,
        audit: Audit | None = None,
        log: Callable[[dict[str, Any]], None] = lambda _: None,
        clock: Callable[[], float] = lambda: 0.0,
        bid_window_s: float = 2.0,
        a2a: bool = False,
        heartbeat: Heartbeat | None = None,
        airspace: Airspace | None = None,
    ) -> None:
        self.key = key
        self.members = {m.uav: m for m in members}
        self.sectors = {s.id: s for s in sectors}
        self.rounds = rounds
        self.verify_k = verify_k
        self.verification = verification or Verification(k=verify_k)
        """Who verifies a casualty: k of n UAVs (``verify_k``), or the finder's operator."""
        self.audit = audit or MemoryAudit()
        self.log = log
        self.clock = clock
        self.coverage: dict[str, list[str]] = {s: [] for s in self.sectors}
        """Sector id → the UAVs that finished a survey of it, one entry per survey."""
        self.casualties: dict[str, Casualty] = {}
        self.failed: list[str] = []
        self.ground_lost = False
        """The ground link is lost: the UAVs allocate among themselves (:meth:`lose_ground`)."""
        self.ground_lost_at: float | None = None
        self._peers: dict[tuple[str, str], A2APeer] = {}
        self.legs = LegBook(airspace or Airspace(), clock=lambda: self.clock(), record=self._record)
        """Every UAV's legs, reserved before it flies them (:mod:`~agentic_core.swarm.leg_gate`)."""
        for member in self.members.values():
            self.legs.prefer(member.uav, member.layer_m)
        self.participants: dict[str, FinderRefuses] = {}
        self.channels: dict[str, LocalChannel | A2AChannel] = {}
        self.guards: dict[str, Guard] = {}
        names = [GROUND, *self.members]
        ground_guard = Guard(key, GROUND, audit=self.audit, members=names)
        for uav, member in self.members.items():
            guard = Guard(key, uav, audit=self.audit, members=names)
            agent = FinderRefuses(Sealer(key, uav), member.state, manager=GROUND, guard=guard)
            self.participants[uav], self.guards[uav] = agent, guard
            self.channels[uav] = self._channel(agent, guard, ground_guard, a2a)
        self.manager = Manager(Sealer(key, GROUND), ground_guard, self.channels, bid_window_s=bid_window_s)
        rule = heartbeat or Heartbeat()
        self.heartbeats = Heartbeats(key, self.guards, clock=clock, period_s=rule.period_s, timeout_s=rule.timeout_s)
        """Without the ground, who lives is who its peers hear (:meth:`alive`)."""
        self._lock = threading.RLock()
        self._agreeing = threading.Lock()
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="swarm-manager", daemon=True)
        self._thread.start()

    def _channel(self, agent: Participant, guard: Guard, ground: Guard, a2a: bool) -> LocalChannel | A2AChannel:
        if not a2a:
            return LocalChannel(agent, guard, reply_guard=ground)
        from agentic_core.swarm.a2a_channel import A2AChannel

        try:
            return A2AChannel(agent, guard, reply_guard=ground, card_key=self.key)
        except Exception:
            self._close_servers()
            raise

    def agents(self) -> dict[str, str]:
        """Each UAV's A2A base URL (its signed Agent Card and JSON-RPC endpoint); empty when in-process."""
        return {uav: ch.url for uav, ch in self.channels.items() if not isinstance(ch, LocalChannel)}

    def a2a_report(self) -> dict[str, dict[str, Any]]:
        """Per UAV served over A2A: its URL and the swarm messages posted to it."""
        return {u: {"url": ch.url, "requests": ch.requests} for u, ch in self.channels.items()
                if not isinstance(ch, LocalChannel)}  # fmt: skip

    # ---- the manager's loop ----

    def call(self, work: Coroutine[Any, Any, T], timeout_s: float = 60.0) -> T:
        """Run ``work`` on the manager's loop and wait for its result."""
        return asyncio.run_coroutine_threadsafe(work, self._loop).result(timeout=timeout_s)

    def close(self) -> None:
        """Stop the manager's loop and the UAVs' A2A servers (idempotent)."""
        if self._loop.is_running():
            for channel in self.channels.values():
                if not isinstance(channel, LocalChannel):
                    self.call(channel.aclose(), timeout_s=5.0)
            for peer in self._peers.values():
                self.call(peer.aclose(), timeout_s=5.0)
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=5.0)
        if not self._loop.is_running() and not self._loop.is_closed():
            self._loop.close()
        self._close_servers()

    def _close_servers(self) -> None:
        for channel in self.channels.values():
            if not isinstance(channel, LocalChannel):
                channel.close()

    def _record(self, event: str, **fields: Any) -> None:
        self.log({"event": event, "sim_t": round(self.clock(), 2), "t": time.time(), **fields})

    def _awards_since(self, before: int) -> None:
        for entry in self.manager.allocation.rounds[before:]:
            task = entry["task"]
            winner = self.manager.allocation.awarded.get(task)
            self._record("round", task=task, bids=entry["bids"], silent=sorted(entry["silent"]), awarded=winner)

    # ---- allocation ----

    def allocate_sectors(self) -> dict[str, str]:
        """Auction every sector (a survey where its centre is, at each bidder's layer); sector id → winner."""
        tasks = [
            SwarmTask(id=f"survey:{s.id}", skill="survey_sector", where=s.centre, work_s=60.0)
            for s in self.sectors.values()
        ]
        self._allocate(tasks)
        awarded = self.manager.allocation.awarded
        return {t.split(":", 1)[1]: uav for t, uav in awarded.items() if t.startswith("survey:")}

    def _allocate(self, tasks: list[SwarmTask], *, exclude: tuple[str, ...] = ()) -> None:
        """Contract Net from the ground; without the ground, consensus among the live UAVs but ``exclude``."""
        if self.ground_lost:
            self.manager.tasks.update({t.id: t for t in tasks})
            self._agree([t.id for t in tasks], exclude=exclude)
            return
        before = len(self.manager.allocation.rounds)
        self.call(self.manager.allocate(tasks))
        self._awards_since(before)

    def fail(self, uav: str, why: str) -> list[str]:
        """``uav`` is lost: its undone tasks auctioned again among the rest. The tasks that moved."""
        with self._lock:
            if uav in self.failed:
                return []
            self.failed.append(uav)
        self.channels[uav].alive = False
        self.legs.release(uav, why, lost=True)
        if self.ground_lost:
            self.manager.failed.add(uav)
            moved = self.manager.allocation.tasks_of(uav)
            self._record("failed", uav=uav, why=why, moved=moved)
            self._agree(moved)
            return moved
        before = len(self.manager.allocation.rounds)
        moved = self.call(self.manager.fail(uav))
        self._record("failed", uav=uav, why=why, moved=moved)
        self._awards_since(before)
        return moved

    def alive(self, uav: str) -> bool:
        """Whether ``uav`` lives: as the ground sees its vehicle; without the ground, whether a live peer has heard
        its signed heartbeat within the timeout."""
        if not self.ground_lost:
            return self.members[uav].alive()
        return self.heartbeats.alive(uav, among=[u for u in self.members if u not in self.failed])

    def watch(self) -> None:
        """Check every member once: one whose vehicle is gone (without the ground: silent) has failed (its tasks
        move); a vehicle gone is lost to the airspace."""
        for uav, member in self.members.items():
            if not member.alive():
                self.legs.release(uav, "its vehicle stopped answering", lost=True)
            holds = self.manager.allocation.tasks_of(uav)  # a UAV that went home with nothing left to do is not lost
            if uav not in self.failed and holds and not self.alive(uav):
                silent = self.heartbeats.silent_s(uav, [u for u in self.members if u not in self.failed])
                self.fail(uav, f"no heartbeat heard for {silent:.1f} s" if self.ground_lost else
                          "its vehicle stopped answering")  # fmt: skip

    def lose_ground(self, why: str) -> dict[str, str]:
        """The ground link is lost (``why``): the ground is called no more. What a live UAV holds stays its own (it
        may be flying it); every other open task, and every task, failure and report from now on, is settled among
        the live UAVs by consensus. Idempotent; the new holders of the tasks that had none."""
        with self._lock:
            if self.ground_lost:
                return {}
            self.ground_lost = True
            self.ground_lost_at = self.clock()
        for channel in self.channels.values():
            channel.alive = False
        allocation = self.manager.allocation
        holders = {u for u in self.members if u not in self.failed and self.members[u].alive()}
        self.heartbeats.start(holders)  # from now on, a UAV lives as long as its peers hear it
        orphans = [
            t for t in self.manager.tasks if t not in allocation.done and allocation.awarded.get(t) not in holders
        ]
        kept = {t: u for t, u in allocation.awarded.items() if t not in allocation.done and u in holders}
        self._record("ground_link_lost", why=why, kept=kept, orphans=orphans)
        return self._agree(orphans) if orphans else {}

    def without_ground(self) -> dict[str, str]:
        """The ground link is gone: the live UAVs share out every task not yet done among themselves by consensus
        (:mod:`~agentic_core.swarm.consensus`, signed messages through their own guards), and each holds what it
        won from then on. Task id → its UAV."""
        return self._agree([t for t in self.manager.tasks if t not in self.manager.allocation.done])

    def _agree(self, open_ids: list[str], *, exclude: tuple[str, ...] = ()) -> dict[str, str]:
        with self._agreeing:  # one consensus at a time: each UAV's server hears the one under way
            return self._agree_now(open_ids, exclude)

    def _agree_now(self, open_ids: list[str], exclude: tuple[str, ...]) -> dict[str, str]:
        allocation = self.manager.allocation
        tasks = [self.manager.tasks[t] for t in open_ids]
        live = [u for u in self.members if u not in (*self.failed, *exclude) and self.alive(u)]
        agents = {
            u: ConsensusAgent(Sealer(self.key, u), self.guards[u], self.members[u].state, max_bundle=len(tasks) or 1)
            for u in live
        }
        for uav, agent in agents.items():
            self.participants[uav].consensus = agent
        over_a2a = self._post_bid if self.agents() else None
        result = agree(agents, tasks, links={u: [v for v in live if v != u] for u in live}, send=over_a2a)
        with self._lock:
            for uav in self.members:
                for task_id in open_ids:
                    self.participants[uav].tasks.pop(task_id, None)
            for task_id in open_ids:
                allocation.awarded.pop(task_id, None)
                allocation.costs.pop(task_id, None)
            for task_id, uav in result.assignment.items():
                allocation.awarded[task_id] = uav
                allocation.costs[task_id] = agents[uav].beliefs[task_id][0]
                self.participants[uav].tasks[task_id] = self.manager.tasks[task_id]
        self._record(
            "consensus", tasks=open_ids, agreed=result.agreed, rounds=result.rounds, awarded=result.assignment,
            unassigned=result.unassigned, among=live,
        )  # fmt: skip
        return dict(result.assignment)

    def _post_bid(self, to: str, message: SwarmMessage) -> bool:
        """One UAV's consensus bids posted to another's A2A endpoint (our client, the sender's guard on the reply);
        whether the receiver's beliefs changed (an unreachable one's did not)."""
        channel = self.channels[to]
        if isinstance(channel, LocalChannel):
            return False
        from agentic_core.swarm.a2a_client import A2APeer

        key = (message.sender, to)
        if key not in self._peers:
            self._peers[key] = A2APeer(channel.url, guard=self.guards[message.sender], card_key=self.key)
        channel.requests += 1
        try:
            reply = self.call(self._peers[key].send(message), timeout_s=10.0)
        except (AgenticUAVError, TimeoutError):
            return False
        return bool(reply is not None and reply.body.get("changed"))

    # ---- what the tools ask ----

    def next_task(self, uav: str) -> dict[str, Any]:
        """The UAV's next work: a verification or delivery first, then its least-covered sector, else ``hold``
        (others are still at work) or ``done``."""
        layer = self.members[uav].layer_m
        held = [t for t in self.participants[uav].tasks.values() if t.id not in self.manager.allocation.done]
        for task in held:
            if task.skill in ("verify_casualty", "deliver_kit"):
                casualty = self.casualties[task.id.split(":", 2)[2]]
                return {"skill": task.skill, "id": task.id, "lat": casualty.lat, "lon": casualty.lon, "alt_m": layer}
        surveys = sorted(
            (t for t in held if t.skill == "survey_sector"), key=lambda t: len(self.coverage[t.id.split(":")[1]])
        )
        if surveys:
            sector = self.sectors[surveys[0].id.split(":")[1]]
            return {"skill": "survey_sector", "id": surveys[0].id, "polygon": sector.corners(), "alt_m": layer}
        lat, lon = self.members[uav].park
        return {"skill": "done" if self.finished() else "hold", "id": "", "lat": lat, "lon": lon, "alt_m": layer}

    def finished(self) -> bool:
        """Whether every task is done (or no live UAV can do what is left): the UAVs may go home."""
        allocation = self.manager.allocation
        open_tasks = [t for t in allocation.awarded if t not in allocation.done]
        return not open_tasks

    def task_done(self, uav: str, task_id: str) -> dict[str, Any]:
        """The UAV finished one piece of ``task_id`` (a survey of its sector, a verification, a delivery)."""
        if self.manager.allocation.awarded.get(task_id) != uav:
            raise AgenticUAVError(f"{uav} does not hold {task_id!r}")
        finished = True
        if task_id.startswith("survey:"):
            sector = task_id.split(":")[1]
            self.coverage[sector].append(uav)
            finished = len(self.coverage[sector]) >= self.rounds
            self._record("covered", uav=uav, sector=sector, surveys=len(self.coverage[sector]))
        elif task_id.startswith("deliver_kit:"):
            self.casualties[task_id.split(":", 2)[2]].delivered = True
            self._record("delivered", uav=uav, casualty=task_id.split(":", 2)[2])
        if finished and self.ground_lost:  # the UAVs keep the books among themselves
            self.participants[uav].tasks.pop(task_id, None)
            self.manager.allocation.done.add(task_id)
        elif finished:
            self.call(self.manager.report(self.participants[uav].report(task_id, done=True)))
        return {"task": task_id, "finished": finished}

    def claim(self, uav: str, object_id: str, cls: str = "person") -> dict[str, Any]:
        """The UAV found ``object_id`` and would respond for the fleet: yes unless another already does (an object of
        the class within :data:`SAME_OBJECT_M` of an earlier claim)."""
        world = self.members[uav].world()
        obj = world.get(object_id) if world is not None else None
        if obj is None:
            raise AgenticUAVError(f"{uav} sees no {object_id!r}")
        here = Point(north=obj.pose.north, east=obj.pose.east)
        with self._lock:
            for casualty in self.casualties.values():
                if casualty.where.horizontal_to(here) <= SAME_OBJECT_M:
                    self._record("claim", uav=uav, object=object_id, claimed=False, by=casualty.finder)
                    return {"claimed": False, "casualty": casualty.id, "by": casualty.finder}
            casualty = Casualty(f"C{len(self.casualties) + 1}", uav, object_id, here, obj.pose.lat, obj.pose.lon)
            self.casualties[casualty.id] = casualty
        self._record("claim", uav=uav, object=object_id, claimed=True, casualty=casualty.id, where=here.model_dump())
        return {"claimed": True, "casualty": casualty.id, "by": uav}

    def seen_by(self, casualty: Casualty) -> list[str]:
        """The UAVs whose World Models hold the casualty now, fused by position (:func:`~.fusion.fuse`)."""
        views = {u: w for u, m in self.members.items() if u not in self.failed and (w := m.world()) is not None}
        if casualty.finder not in views:
            return []
        fleet = fuse(views)
        found = fleet.fleet_id(casualty.finder, casualty.object_id)
        return sorted(fleet.seen_by(found)) if found is not None else []

    def verify(self, uav: str, casualty_id: str, timeout_s: float, wait: Callable[[], None]) -> dict[str, Any]:
        """Ask another UAV (Contract Net) to look at the casualty; wait until ``verify_k`` UAVs see it, or
        ``timeout_s`` of simulated time. ``wait`` pauses between looks."""
        casualty = self.casualties[casualty_id]
        if casualty.finder != uav:
            raise AgenticUAVError(f"{casualty_id} was found by {casualty.finder}, not {uav}")
        if self.verification.by == "operator":
            seen = self.seen_by(casualty)
            answer, casualty.verified = ask_operator(casualty, self.members[uav].ask, self.verification, seen)
            casualty.verified_by = seen
            self._record("verify", uav=uav, casualty=casualty_id, by="operator", answer=answer,
                         verified=casualty.verified, seen_by=seen)  # fmt: skip
            return {"verified": casualty.verified, "seen_by": seen, "by": "operator", "answer": answer}
        if self.verify_k > 1:
            task = SwarmTask(id=f"verify_casualty:{uav}:{casualty_id}", skill="verify_casualty", where=casualty.where)
            self._allocate([task], exclude=(uav,))
        deadline = self.clock() + timeout_s
        seen = self.seen_by(casualty)
        while len(seen) < self.verify_k and self.clock() < deadline:
            wait()
            seen = self.seen_by(casualty)
        casualty.verified_by = seen
        verified = casualty.verified = len(seen) >= self.verify_k
        self._record("verify", uav=uav, casualty=casualty_id, seen_by=seen, k=self.verify_k, verified=verified)
        task_id = f"verify_casualty:{uav}:{casualty_id}"
        holder = self.manager.allocation.awarded.get(task_id)
        if holder is not None and task_id not in self.manager.allocation.done:
            self.task_done(holder, task_id)  # verified or given up: the verifier goes back to its sector
        return {"verified": verified, "seen_by": seen, "k": self.verify_k}

    def clearance(
        self, uav: str, task_id: str, horizontal_m: float, timeout_s: float, wait: Callable[[], None]
    ) -> dict[str, Any]:
        """Wait until no other UAV is airborne within ``horizontal_m`` of the task's place (a UAV about to descend
        there through the lower layers), or ``timeout_s`` of simulated time; whether it is clear."""
        casualty = self.casualties[task_id.split(":", 2)[2]]
        deadline = self.clock() + timeout_s

        def near() -> list[str]:
            return sorted(
                other
                for other, member in self.members.items()
                if other != uav and other not in self.failed and member.alive()
                and (state := member.state()).position.alt > 1.0
                and state.position.horizontal_to(casualty.where) < horizontal_m
            )  # fmt: skip

        blocking = near()
        while blocking and self.clock() < deadline:
            wait()
            blocking = near()
        self._record("clearance", uav=uav, task=task_id, clear=not blocking, blocking=blocking)
        return {"clear": not blocking, "blocking": blocking}

    def deliver(self, uav: str, casualty_id: str) -> dict[str, Any]:
        """Auction the kit's delivery to the casualty (only a UAV with a medkit bids); the award."""
        casualty = self.casualties[casualty_id]
        task = SwarmTask(
            id=f"deliver_kit:{uav}:{casualty_id}", skill="deliver_kit", where=casualty.where, needs="medkit"
        )
        self._allocate([task])
        allocation = self.manager.allocation
        casualty.delivery = allocation.awarded.get(task.id)
        return {"awarded": casualty.delivery, "cost": allocation.costs.get(task.id)}


__all__ = ["GROUND", "Casualty", "FinderRefuses", "Member", "SwarmCoordinator"]
