"""How fast the simulated F450 runs, in simulated seconds per wall-clock second.

Cases, in one run:

* (a) bare JSBSim: the F450 model stepped at 250 Hz with a fixed hover throttle, no Python above it;
* (b) our simulator: JSBSim plus the 50 Hz flight controller, battery, gusts and GPS noise, taking off and holding
  a hover (with a 3 m/s gusty wind so the controller has work to do);
* (c) the MAVLink vehicle (:class:`flight.mavlink.MavlinkVehicle`) flying the same hover, running free on its
  thread (``start(speed=None)``, as ``agentic-uav sim --speed max``) and streaming its telemetry at the default rates
  to a pymavlink ground station in another process, which sends a HEARTBEAT every wall second as a ground station
  does. The client counts what it receives, so the report also says whether the streams kept their rates.
  With ``--signing on`` (the default) vehicle and client share a MAVLink 2 signing key: the vehicle signs every
  frame and checks the client's; ``--signing off`` flies it unsigned.

The report also gives the cost of signing per message, timed in this process: packing a GLOBAL_POSITION_INT
unsigned (the vehicle's fast path) and signed (pymavlink's path with the signature), and checking a signed frame
as the vehicle does (:meth:`flight.signing.Signer.check`).

The client drains its socket every 10 ms (``--client poll``, the default) rather than sleeping in ``select`` until
each datagram (``--client select``): a sleeping receiver is woken by every datagram and the *sender* pays for the
wake-up, on this kind of VM tens of microseconds per datagram, which at a few hundred times real time (thousands of
datagrams per second) costs the vehicle a large share of its speed. At real time either client is fine.

Targets for (c): at least 50× real time, and at least half of (a). Each case is timed ``--repeats`` times over
``--seconds`` of simulated flight, the cases interleaved so that a burst of load elsewhere hits all of them alike;
the best run of each is reported, with every run's rate, the ratios (b)/(a) and (c)/(a) and the load average.
Wall-clock rates are the measure; the report adds the same rates per second of CPU used by the benchmark's process
(user + system, all threads), which shows what the machine would give without the other work sharing its CPUs.

Usage: ``python benchmarks/sim_speed.py [--seconds 60] [--repeats 3] [--quick] [--client poll|select]
[--signing on|off] [--strict]``.
Exit status 0 whether the targets are met or not (``--strict``: 1 on MISS).
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import os
import socket
import sys
import time
from collections import Counter
from dataclasses import dataclass, field
from multiprocessing.connection import Connection
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from flight.sim import F450Model, Simulator, WindSettings  # noqa: E402
from flight.sim.jsbsim_model import DT, HOVER_THROTTLE  # noqa: E402

TABLE_HEADER = "simulator speed benchmark"
TARGET_REAL_TIME = 50.0
TARGET_FRACTION_OF_A = 0.5
WIND = WindSettings(east_mps=3.0, gust_std_mps=1.0)
CLIENT_POLL_S = 0.01


@dataclass
class Run:
    """One timed run: simulated seconds flown, wall seconds and CPU seconds (this process) it took."""

    sim_s: float
    wall_s: float
    cpu_s: float
    received: dict[str, int] = field(default_factory=dict)
    expected: dict[str, float] = field(default_factory=dict)

    @property
    def rate(self) -> float:
        return self.sim_s / self.wall_s

    @property
    def cpu_rate(self) -> float:
        return self.sim_s / self.cpu_s if self.cpu_s > 0 else math.inf

    @property
    def delivered(self) -> float:
        """Messages received over messages the default rates promise for the simulated time flown."""
        want = sum(self.expected.values())
        return sum(self.received.get(k, 0) for k in self.expected) / want if want else 0.0


class Stopwatch:
    def __enter__(self) -> Stopwatch:
        self.wall0, self.cpu0 = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc: object) -> None:
        self.wall = time.perf_counter() - self.wall0
        self.cpu = time.process_time() - self.cpu0


def bare_jsbsim(seconds: float) -> Run:
    model = F450Model(21.4133, 39.8933, 300.0)
    model.set_engaged(True)
    model.set_controls(HOVER_THROTTLE, 0.0, 0.0, 0.0)
    steps = round(seconds / DT)
    with Stopwatch() as w:
        model.step(steps)
    return Run(seconds, w.wall, w.cpu)


def with_controller(seconds: float) -> Run:
    sim = Simulator(seed=1)
    sim.set_wind(WIND)
    sim.arm()
    sim.takeoff(10.0)
    with Stopwatch() as w:
        sim.run_for(seconds)
    return Run(seconds, w.wall, w.cpu)


# -- (c): the vehicle and a ground station in another process --------------------------------------------------------


def ground_station(port: int, ready: Connection, stop: Connection, poll_s: float, key: bytes | None = None) -> None:
    """The client process: receive everything the vehicle streams, count it by type, send a HEARTBEAT every wall
    second (pymavlink, as a script or MAVProxy would); the counts go back through ``stop`` when told to stop.
    ``poll_s`` > 0 drains the socket that often; 0 sleeps in ``select`` until each datagram."""
    os.environ.setdefault("MAVLINK20", "1")
    from pymavlink import mavutil

    link = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=190)
    if key is not None:
        from flight.signing import now_timestamp

        link.setup_signing(key, sign_outgoing=True, initial_timestamp=now_timestamp(), link_id=1)
    counts: Counter[str] = Counter()
    ready.send(True)
    next_beat = 0.0
    while not stop.poll():
        if poll_s > 0:
            time.sleep(poll_s)
            msg = link.recv_match(blocking=False)
        else:
            msg = link.recv_match(blocking=True, timeout=0.05)
        while msg is not None:
            counts[msg.get_type()] += 1
            msg = link.recv_match(blocking=False)
        now = time.monotonic()
        if now >= next_beat:  # (a udpin link sends only once it has heard the vehicle)
            link.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            next_beat = now + 1.0
    stop.recv()
    stop.send(dict(counts))
    link.close()


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def mavlink_vehicle(seconds: float, poll_s: float = CLIENT_POLL_S, key: bytes | None = None) -> Run:
    from pymavlink.dialects.v20 import common as mavlink2

    from flight.mavlink import DEFAULT_RATES_HZ, MavlinkVehicle

    port = free_port()
    ctx = mp.get_context("spawn")
    ready_rx, ready_tx = ctx.Pipe(duplex=False)
    stop_here, stop_there = ctx.Pipe()
    client = ctx.Process(target=ground_station, args=(port, ready_tx, stop_there, poll_s, key), daemon=True)
    client.start()
    try:
        if not ready_rx.poll(30.0):
            raise RuntimeError("the ground-station process did not start")
        ready_rx.recv()
        sim = Simulator(seed=1)
        sim.set_wind(WIND)
        with MavlinkVehicle(sim, gcs=("127.0.0.1", port), api=None, signing_key=key) as vehicle:
            vehicle.navigator.arm()
            vehicle.navigator.takeoff(10.0)
            sim0 = sim.time_s
            with Stopwatch() as w:
                vehicle.start(speed=None)
                while sim.time_s - sim0 < seconds:  # rarely: each wake-up takes the GIL from the vehicle's thread
                    time.sleep(0.02)
                vehicle.stop()
            flown = sim.time_s - sim0
        time.sleep(0.2)  # let the client read what is still in its socket
        stop_here.send(True)
        received = stop_here.recv() if stop_here.poll(10.0) else {}
        # Each stream sends at once and then every 1/rate: floor(rate × time) + 1 messages over the flight.
        rates = {mavlink2.mavlink_map[i].msgname: hz for i, hz in DEFAULT_RATES_HZ.items()}
        expected = {name: math.floor(hz * flown + 1e-9) + 1.0 for name, hz in rates.items()}
        return Run(flown, w.wall, w.cpu, received, expected)
    finally:
        client.join(timeout=5.0)
        if client.is_alive():
            client.terminate()


def signing_cost(n: int = 20000) -> tuple[float, float, float]:
    """CPU µs per message (this process's CPU time: the machine's other load does not inflate it): packing a
    GLOBAL_POSITION_INT unsigned (fast path) and signed, and checking a signed one."""
    from pymavlink.dialects.v20 import common as mavlink2

    from flight.mavlink.telemetry import GLOBAL_POSITION_INT
    from flight.signing import Signer, new_key

    fields = (1000, 214133000, 398933000, 310000, 10000, 12, -3, 0, 9000)
    key = new_key()
    plain = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    signed = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    Signer(key).attach(signed)
    t0 = time.process_time()
    for _ in range(n):
        GLOBAL_POSITION_INT.pack(plain, fields)
    t1 = time.process_time()
    frames = [GLOBAL_POSITION_INT.pack(signed, fields) for _ in range(n)]
    t2 = time.process_time()
    parser = mavlink2.MAVLink(None)
    msgs = [parser.decode(bytearray(f)) for f in frames]
    checker = Signer(key, required=True)
    t3 = time.process_time()
    for msg in msgs:
        checker.check(msg)
    t4 = time.process_time()
    if checker.counters.signed != n:
        raise RuntimeError(f"only {checker.counters.signed} of {n} signed frames checked good")
    return (t1 - t0) / n * 1e6, (t2 - t1) / n * 1e6, (t4 - t3) / n * 1e6


# -- the report -------------------------------------------------------------------------------------------------------


def verdict(ok: bool) -> str:
    return "PASS" if ok else "MISS"


def row(label: str, runs: list[Run]) -> str:
    best = max(runs, key=lambda r: r.rate)
    every = " ".join(f"{r.rate:.0f}" for r in runs)
    return f"{label:<40} {best.rate:>9.0f}x {max(r.cpu_rate for r in runs):>9.0f}x   {every}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="10 s, one repeat (smoke test)")
    parser.add_argument("--client", choices=("poll", "select"), default="poll", help="how the ground station reads")
    parser.add_argument("--signing", choices=("on", "off"), default="on", help="sign the MAVLink link in (c)")
    parser.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    args = parser.parse_args(argv)
    from flight.signing import new_key

    key = new_key() if args.signing == "on" else None
    seconds, repeats = (10.0, 1) if args.quick else (args.seconds, args.repeats)
    poll_s = CLIENT_POLL_S if args.client == "poll" else 0.0

    load_before = os.getloadavg()
    a_runs: list[Run] = []
    b_runs: list[Run] = []
    c_runs: list[Run] = []
    for _ in range(repeats):  # interleaved: load elsewhere on the machine hits every case alike
        a_runs.append(bare_jsbsim(seconds))
        b_runs.append(with_controller(seconds))
        c_runs.append(mavlink_vehicle(seconds, poll_s, key))
    load_after = os.getloadavg()
    a = max(r.rate for r in a_runs)
    b = max(r.rate for r in b_runs)
    c_best = max(c_runs, key=lambda r: r.rate)
    c = c_best.rate
    a_cpu = max(r.cpu_rate for r in a_runs)
    c_cpu = max(r.cpu_rate for r in c_runs)

    print(TABLE_HEADER)
    print(f"{seconds:g} simulated seconds per run, best of {repeats}; physics at 250 Hz; client: {args.client}")
    print(f"load average (1 min) {load_before[0]:.2f} before, {load_after[0]:.2f} after, on {os.cpu_count()} CPUs")
    print(f"{'case':<40} {'sim s/wall s':>10} {'sim s/CPU s':>10}   every run (wall)")
    print(row("(a) bare JSBSim F450", a_runs))
    print(row("(b) simulator + controller (50 Hz)", b_runs))
    print(row(f"(c) MAVLink vehicle + client, signing {args.signing}", c_runs))
    print(f"ratio (b)/(a): {b / a:.2f}")
    print(f"ratio (c)/(a): {c / a:.2f} (per CPU second: {c_cpu / a_cpu:.2f})")
    got = sum(c_best.received.get(k, 0) for k in c_best.expected)
    print(
        f"telemetry in (c): the client received {got} of {sum(c_best.expected.values()):.0f} streamed messages"
        f" ({c_best.delivered:.1%}) at the default rates"
    )
    plain_us, signed_us, check_us = signing_cost()
    print(
        f"signing cost per message (CPU time): pack {plain_us:.1f} us unsigned, {signed_us:.1f} us signed"
        f" (+{signed_us - plain_us:.1f} us); check a signed frame {check_us:.1f} us"
    )
    fast = c >= TARGET_REAL_TIME
    half = c >= TARGET_FRACTION_OF_A * a
    print("Targets")
    print(f"  (c) >= {TARGET_REAL_TIME:.0f}x real time: {verdict(fast)} ({c:.0f}x)")
    print(f"  (c) >= {TARGET_FRACTION_OF_A:g} x (a): {verdict(half)} ({c / a:.2f})")
    return 1 if args.strict and not (fast and half) else 0


if __name__ == "__main__":
    raise SystemExit(main())
