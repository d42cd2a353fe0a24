"""The swarm's costs on this machine: Contract Net's allocation of 50 tasks among 25 UAVs (every message signed,
sent as JSON, checked by the receiver's guard, over in-process channels, so the protocol's own time is measured and
not the network's), the optimality gap of that allocation against ``scipy.optimize.linear_sum_assignment`` over
the same costs, the same allocation over A2A on 127.0.0.1 for a smaller fleet (``--a2a N``), and the reservation
of one leg per UAV in the deconflicted airspace.

Last, simulated seconds per wall second for 1, 4, 10 and 25 F450s in lockstep on one clock, each taken off to
20 m: the physics alone (``flight.sim.Simulator``, all advanced 0.1 s at a time), then the vehicles as
``agentic-uav swarm run`` ticks them (``flight.mavlink.lockstep.Lockstep`` over ``MavlinkVehicle``: physics,
autopilot, failsafes, MAVLink streams, and a telemetry sample built every tick for its hooks), without perception
or the agents. Goal: 10 vehicles at 10x real time or more.
Usage: ``python benchmarks/swarm.py [--uavs 25] [--tasks 50] [--runs 5] [--a2a 4] [--sim-s 10] [--quick]``.
Exit status 0.
"""

from __future__ import annotations

import argparse
import asyncio
import random
import statistics
import time
from collections.abc import Callable, Mapping

from agentic_core.contracts.swarm import Point, SwarmTask, UavState
from agentic_core.swarm.a2a_client import A2APeer
from agentic_core.swarm.a2a_server import A2AServer
from agentic_core.swarm.contract_net import Channel, LocalChannel, Manager, Participant
from agentic_core.swarm.deconflict import Airspace
from agentic_core.swarm.optimal import optimality_gap
from agentic_core.swarm.signing import Guard, Sealer, SwarmKey
from flight.mavlink import MavlinkVehicle
from flight.mavlink.lockstep import Lockstep
from flight.sim.simulator import Simulator

KEY = SwarmKey("bench", b"b" * 32)
TARGET_S = 1.0
"""Goal: 25 UAVs × 50 tasks allocated in under a second."""


def fleet(n_uavs: int, n_tasks: int, seed: int) -> tuple[list[UavState], list[SwarmTask]]:
    rng = random.Random(seed)
    uavs = [
        UavState(
            uav_id=f"uav-{i + 1}",
            position=Point(north=rng.uniform(-500, 500), east=rng.uniform(-500, 500), alt=30),
            battery_pct=rng.uniform(50, 100),
            payload=("medkit",) if i % 3 == 0 else (),
        )
        for i in range(n_uavs)
    ]
    tasks = [
        SwarmTask(
            id=f"T-{j + 1}",
            skill="deliver_kit" if j % 10 == 0 else "survey_sector",
            where=Point(north=rng.uniform(-600, 600), east=rng.uniform(-600, 600), alt=30),
            needs="medkit" if j % 10 == 0 else None,
            work_s=rng.uniform(30, 240),
        )
        for j in range(n_tasks)
    ]
    return uavs, tasks


def _constant(state: UavState) -> Callable[[], UavState]:
    return lambda: state


def participant(state: UavState) -> Participant:
    return Participant(Sealer(KEY, state.uav_id), _constant(state), manager="ground")


async def allocate(members: Mapping[str, Channel], tasks: list[SwarmTask]) -> tuple[float, dict[str, str]]:
    manager = Manager(Sealer(KEY, "ground"), Guard(KEY, "ground"), members, bid_window_s=5.0)
    started = time.perf_counter()
    allocation = await manager.allocate(tasks)
    return time.perf_counter() - started, allocation.awarded


def in_process(uavs: list[UavState], tasks: list[SwarmTask]) -> tuple[float, dict[str, str]]:
    members: dict[str, Channel] = {u.uav_id: LocalChannel(participant(u), Guard(KEY, u.uav_id)) for u in uavs}
    return asyncio.run(allocate(members, tasks))


def over_a2a(uavs: list[UavState], tasks: list[SwarmTask]) -> float:
    servers = [A2AServer(participant(u), Guard(KEY, u.uav_id)) for u in uavs]

    async def run() -> float:
        guard = Guard(KEY, "ground")
        peers = {u.uav_id: A2APeer(s.url, guard=guard) for u, s in zip(uavs, servers, strict=True)}
        try:
            took, _ = await allocate(peers, tasks)
            return took
        finally:
            for peer in peers.values():
                await peer.aclose()

    try:
        return asyncio.run(run())
    finally:
        for server in servers:
            server.close()


def deconflict(uavs: list[UavState], tasks: list[SwarmTask]) -> float:
    airspace = Airspace()
    started = time.perf_counter()
    for i, (uav, task) in enumerate(zip(uavs, tasks, strict=False)):
        launch = Point(north=-700.0, east=-500.0 + 40.0 * i, alt=0.0)  # a launch line: pads 40 m apart
        airspace.reserve(uav.uav_id, launch, task.where, t0=0.0)
    return time.perf_counter() - started


def lockstep(n: int, sim_s: float) -> float:
    """Simulated seconds per wall second of ``n`` simulators stepped together, 0.1 s at a time."""
    sims = [Simulator(seed=i) for i in range(n)]
    for sim in sims:
        sim.arm()
        sim.takeoff(20.0)
    chunk = round(0.1 / sims[0].dt)
    started = time.perf_counter()
    for _ in range(round(sim_s / 0.1)):
        for sim in sims:
            sim.step(chunk)
    return sim_s / (time.perf_counter() - started)


def lockstep_vehicles(n: int, sim_s: float) -> float:
    """Simulated seconds per wall second of ``n`` MAVLink vehicles on one :class:`Lockstep` clock."""
    vehicles = [MavlinkVehicle(Simulator(seed=i), gcs=None, api=None, system_id=i + 1) for i in range(n)]
    samples = [0]
    try:
        for vehicle in vehicles:
            vehicle.sim.arm()
            vehicle.sim.takeoff(20.0)
            vehicle.on_telemetry.append(lambda _sample: samples.__setitem__(0, samples[0] + 1))
        clock = Lockstep(vehicles)
        started = time.perf_counter()
        clock.run_for(sim_s)
        return sim_s / (time.perf_counter() - started)
    finally:
        for vehicle in vehicles:
            vehicle.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--uavs", type=int, default=25)
    parser.add_argument("--tasks", type=int, default=50)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--a2a", type=int, default=4, metavar="N", help="UAVs in the A2A run (0: none)")
    parser.add_argument("--sim-s", type=float, default=10.0, help="simulated seconds of the lockstep runs")
    parser.add_argument("--quick", action="store_true", help="one run, a small A2A fleet, short lockstep runs")
    args = parser.parse_args()
    runs = 1 if args.quick else args.runs
    times, gaps = [], []
    for seed in range(runs):
        uavs, tasks = fleet(args.uavs, args.tasks, seed)
        took, awarded = in_process(uavs, tasks)
        times.append(took)
        gaps.append(optimality_gap(uavs, tasks, awarded).relative)
    median = statistics.median(times)
    print(f"Contract Net, {args.uavs} UAVs x {args.tasks} tasks, in process ({runs} runs)")
    print(
        f"{'allocation time (median)':<40} {median * 1000:9.1f} ms  target < {TARGET_S * 1000:g} ms  "
        f"{'PASS' if median < TARGET_S else 'MISS'}"
    )
    print(
        f"{'messages per allocation':<40} {args.tasks * (2 * args.uavs + 2):9d}   (cfp + bid per UAV, award + accept)"
    )
    print(f"{'optimality gap (median, max)':<40} {statistics.median(gaps):9.1%}  {max(gaps):.1%}")
    if args.a2a:
        n = 2 if args.quick else args.a2a
        uavs, tasks = fleet(n, 2 * n, 0)
        print(f"{f'over A2A on 127.0.0.1, {n} UAVs x {2 * n} tasks':<40} {over_a2a(uavs, tasks) * 1000:9.1f} ms")
    uavs, tasks = fleet(args.uavs, args.tasks, 0)
    print(f"{f'deconflicted legs, {args.uavs} UAVs (one each)':<40} {deconflict(uavs, tasks) * 1000:9.1f} ms")
    sim_s = 1.0 if args.quick else args.sim_s
    for n in (1, 4) if args.quick else (1, 4, 10, 25):
        rate = lockstep(n, sim_s)
        print(f"{f'lockstep physics, {n} vehicles':<40} {rate:9.1f} x real time")
    for n in (1, 4) if args.quick else (1, 4, 10, 25):
        rate = lockstep_vehicles(n, sim_s)
        print(f"{f'lockstep MAVLink vehicles, {n} vehicles':<40} {rate:9.1f} x real time  (goal for 10: >= 10x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
