"""Allocation without the ground: a consensus-based bundle algorithm (CBBA's two phases) among the UAVs themselves,
for when the manager cannot be reached. Each UAV builds a bundle of tasks greedily by marginal cost (its path
through them: :func:`~agentic_core.swarm.cost.task_cost`), each bid raised to at least the bundle's last (bid
warping: a path's marginal costs need not rise, and CBBA converges only on bids that do), then tells every other
UAV its own bids — one signed ``bid`` message each, checked by the receiver's guard — and each keeps, per task, the
best bid (lower marginal cost; the lower UAV id on a tie); a UAV outbid on a task of its bundle drops it and every
task after it (their marginal costs were counted from it). Rounds repeat until no belief changes.

Each UAV speaks only for its own bids and every UAV hears every other (a full mesh, as the UAVs' A2A endpoints are
to each other): beliefs are not relayed, so CBBA's timestamps for relayed, possibly stale, bids are not needed.

>>> from agentic_core.contracts.swarm import Point, SwarmTask, UavState
>>> from agentic_core.swarm.signing import Guard, Sealer, SwarmKey
>>> key = SwarmKey.generate("mina")
>>> def uav(name: str, north: float) -> ConsensusAgent:
...     state = UavState(uav_id=name, position=Point(north=north, east=0, alt=30), battery_pct=90)
...     return ConsensusAgent(Sealer(key, name), Guard(key, name), lambda: state)
>>> tasks = [SwarmTask(id=f"T-{n}", skill="survey_sector", where=Point(north=n, east=0, alt=30)) for n in (0, 500)]
>>> agents = {"a": uav("a", 0), "b": uav("b", 480)}
>>> result = agree(agents, tasks, links={"a": ["b"], "b": ["a"]})
>>> result.assignment, result.agreed
({'T-0': 'a', 'T-500': 'b'}, True)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

from agentic_core.contracts.swarm import SwarmMessage, SwarmTask, UavState
from agentic_core.swarm.cost import DEFAULT, CostModel, task_cost
from agentic_core.swarm.signing import Guard, Refused, Sealer

Belief = tuple[float, str]
"""(marginal cost of the best bid, its bidder); no bid: (inf, "")."""
NONE: Belief = (float("inf"), "")
MAX_BUNDLE = 8


def _better(a: Belief, b: Belief) -> bool:
    """Whether bid ``a`` beats ``b``: cheaper, or as cheap from the lower id."""
    return a[0] < b[0] or (a[0] == b[0] and a[1] != "" and (b[1] == "" or a[1] < b[1]))


class ConsensusAgent:
    """One UAV's side of the consensus: its bundle, its beliefs, its signed messages."""

    def __init__(
        self,
        sealer: Sealer,
        guard: Guard,
        state: Callable[[], UavState],
        *,
        model: CostModel = DEFAULT,
        max_bundle: int = MAX_BUNDLE,
    ) -> None:
        self.sealer = sealer
        self.guard = guard
        self.state = state
        self.model = model
        self.max_bundle = max_bundle
        self.bundle: list[SwarmTask] = []
        self.beliefs: dict[str, Belief] = {}

    @property
    def uav(self) -> str:
        return self.sealer.sender

    def _path(self, bundle: Sequence[SwarmTask]) -> float | None:
        """Seconds to fly and work through ``bundle``; before any task, the battery's penalty alone (the same for
        every path, so it is no task's marginal cost)."""
        if not bundle:
            state = self.state()
            return self.model.battery_weight_s * (1.0 - state.battery_pct / 100.0)
        return task_cost(self.state(), bundle[-1], committed=list(bundle[:-1]), model=self.model)

    def build(self, tasks: Sequence[SwarmTask]) -> None:
        """Phase 1: add tasks to the bundle, cheapest marginal cost first, while it beats what this UAV believes."""
        while len(self.bundle) < self.max_bundle:
            base = self._path(self.bundle)
            if base is None:
                return
            best: tuple[float, SwarmTask] | None = None
            held = {t.id for t in self.bundle}
            for task in tasks:
                if task.id in held:
                    continue
                total = self._path([*self.bundle, task])
                if total is None:
                    continue
                floor = self.beliefs[self.bundle[-1].id][0] if self.bundle else 0.0
                bid = (max(total - base, floor), self.uav)  # warped: never below the bundle's last bid
                if _better(bid, self.beliefs.get(task.id, NONE)) and (best is None or bid[0] < best[0]):
                    best = (bid[0], task)
            if best is None:
                return
            self.bundle.append(best[1])
            self.beliefs[best[1].id] = (best[0], self.uav)

    def message(self, to: str) -> SwarmMessage:
        """This UAV's own bids (its bundle and their marginal costs), signed, for ``to``."""
        body = {
            "bids": {t.id: self.beliefs[t.id][0] for t in self.bundle if self.beliefs.get(t.id, NONE)[1] == self.uav}
        }
        return self.sealer.seal("bid", body, recipient=to, conversation="consensus")

    def hear(self, raw: str) -> bool:
        """Phase 2 with one UAV's message (JSON off the wire): its bids replace what this UAV believed of its bids;
        each task keeps the better bid; what this UAV was outbid on is released. Whether anything changed. A refused
        or malformed message changes nothing (a refusal is audited)."""
        try:
            message = self.guard.parse(raw)
        except Refused:
            return False
        return self.take(message)

    def take(self, message: SwarmMessage) -> bool:
        """Phase 2 with one UAV's message its guard has already verified (an A2A server's); whether anything changed."""
        bids = message.body.get("bids")
        sender = message.sender
        if message.kind != "bid" or not isinstance(bids, dict) or sender == self.uav:
            return False
        changed = False
        for task_id, (_, winner) in list(self.beliefs.items()):
            if winner == sender and task_id not in bids:  # it no longer bids: it released the task
                self.beliefs[task_id] = NONE
                changed = True
        for task_id, cost in bids.items():
            if not isinstance(cost, int | float) or isinstance(cost, bool) or cost < 0:
                continue
            bid: Belief = (float(cost), sender)
            mine = self.beliefs.get(task_id, NONE)
            if mine != bid and (mine[1] == sender or _better(bid, mine)):
                self.beliefs[task_id] = bid
                changed = True
        lost = next((i for i, t in enumerate(self.bundle) if self.beliefs.get(t.id, NONE)[1] != self.uav), None)
        if lost is not None:
            for task in self.bundle[lost + 1 :]:  # counted from the lost one: no longer this UAV's price
                if self.beliefs.get(task.id, NONE)[1] == self.uav:
                    self.beliefs[task.id] = NONE
            del self.bundle[lost:]
            changed = True
        return changed


@dataclass
class Agreement:
    """Where the consensus ended: each task's winner, whether every UAV believes the same, how many rounds."""

    assignment: dict[str, str] = field(default_factory=dict)
    agreed: bool = False
    rounds: int = 0
    unassigned: list[str] = field(default_factory=list)
    bundles: dict[str, list[str]] = field(default_factory=dict)


def agree(
    agents: Mapping[str, ConsensusAgent],
    tasks: Sequence[SwarmTask],
    *,
    links: Mapping[str, Sequence[str]],
    max_rounds: int = 100,
    deliver: Callable[[str, SwarmMessage], str] | None = None,
    send: Callable[[str, SwarmMessage], bool] | None = None,
) -> Agreement:
    """Run the consensus over ``links`` (uav → the neighbours it hears) until nothing changes; ``deliver`` carries a
    message to its recipient as JSON (default: as it is), where a test may tamper with it; ``send``, when given,
    carries it instead to where the recipient hears it (over A2A) and says whether its beliefs changed."""
    carry = deliver or (lambda _to, message: message.model_dump_json())
    rounds = 0
    for rounds in range(1, max_rounds + 1):  # noqa: B007 (the last round is reported)
        grew = False
        for agent in agents.values():
            before = len(agent.bundle)
            agent.build(tasks)
            grew |= len(agent.bundle) != before
        outbox = [(to, agent.message(to)) for name, agent in agents.items() for to in links.get(name, ())]
        changed = False
        for to, message in outbox:
            if to in agents:
                changed |= send(to, message) if send is not None else agents[to].hear(carry(to, message))
        if not changed and not grew:
            break
    owners: dict[str, str] = {}
    for name, agent in agents.items():
        for task in agent.bundle:
            owners.setdefault(task.id, name)
    views = [{t.id: agent.beliefs.get(t.id, NONE)[1] for t in tasks} for agent in agents.values()]
    agreed = (
        bool(views) and all(v == views[0] for v in views) and all(owners.get(t) == w for t, w in views[0].items() if w)
    )
    return Agreement(
        assignment=owners,
        agreed=agreed,
        rounds=rounds,
        unassigned=[t.id for t in tasks if t.id not in owners],
        bundles={name: [t.id for t in agent.bundle] for name, agent in agents.items()},
    )


__all__ = ["Agreement", "ConsensusAgent", "agree"]
